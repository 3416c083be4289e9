# temporary: the estimator's time at 128^3 on the GPU, split (not kept)
set -e
patch -p1 -s < .device/prof3.patch
. bench/gpu/lib.sh
build_gpu -- src/cli/petblur
install_nibabel
cd bench && python3 -c "
import numpy as np, nibabel as nib, json, estimate_validation as ev, head_frames as hf
s=ev.SETUPS['fine']; rng=np.random.default_rng(3418080377)
frames, affine, bounds, truth = hf.simulate(s, rng)
nib.save(nib.Nifti1Image(frames, affine), '/tmp/f.nii')
json.dump({'FrameTimesStart': bounds[:-1].tolist(), 'FrameDuration': np.diff(bounds).tolist()}, open('/tmp/f.json','w'))
" && cd ..
for i in 1 2 3; do /usr/bin/time -v env PB_PROFILE=1 build-gpu/src/cli/petblur motion estimate /tmp/f.nii --frames-from /tmp/f.json -o /tmp/t$i.csv --device cuda -q 2>&1 | grep -E "PROFILE|Elapsed|User time"; done
cmp /tmp/t1.csv .device/track-before.csv && echo same-track-as-before
/usr/bin/time -v build-gpu/src/cli/petblur motion estimate /tmp/f.nii --frames-from /tmp/f.json -o /tmp/t9.csv --device cuda --frame-poses-only -q 2>&1 | grep -E "Elapsed"
