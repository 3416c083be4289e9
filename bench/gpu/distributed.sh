#: distributed             issue 34 on one or more GPUs: test_gpu.py, distributed_frames.py and the distributed MLEM on 1 and every GPU (NCCL)
# The program (for the study's phantom) built with CUDA, the package installed
# by pip beside the machine's torch, Dask's wheels beside it (all from .whl/).
# Then
#  - python/tests/test_gpu.py: 'cuda' as the current device, two Dask workers
#    sharing one GPU equal to one process, and the rest of the GPU suite;
#  - bench/distributed_frames.py on 1 and on every GPU (NCCL): 24 frames of
#    256^3, forward + summed adjoint + all_reduce, and the parallel efficiency;
#  - examples/motion_study/mlem_distributed.py, the full preset, on 1 and on
#    every GPU (NCCL), and the two images compared.
# On one GPU the two-GPU rows say so. ASTRA cannot load there: its matrix
# travels as .study/astra-128-180.npz (mode study says how it is made).
# NCCL_NVLS_ENABLE and the machine's other multicast settings are left as
# they are. Back through $OUT: machine.txt, pytest.txt, frames-N.json,
# frames.md, mlem-N.log, mlem-N.json, images.txt. (carry .device .whl .study)
# shellcheck shell=bash
mode_distributed() (
    gpus=$(nvidia-smi -L | wc -l)
    write_machine "$OUT/machine.txt" <<<"gpus: $gpus; NCCL_NVLS_ENABLE=${NCCL_NVLS_ENABLE-unset}"
    build_gpu -Dopencl=disabled -- src/cli/petblur
    install_package -Dopencl=disabled || exit 1
    python3 -m pip install -q --no-deps --no-index --find-links .whl --target "$PYTHONPATH" dask distributed toolz \
        partd locket sortedcontainers tblib zict msgpack tornado psutil click pyyaml cloudpickle fsspec 2>&1 | tail -3
    export PETBLUR_CLI=$PWD/build-gpu/src/cli/petblur
    status=0

    echo "== pytest python/tests/test_gpu.py =="
    (cd /tmp && timeout 240 python3 -m pytest -v -p no:cacheprovider "$OLDPWD/python/tests/test_gpu.py") \
        >"$OUT/pytest.txt" 2>&1 || status=1
    tail -25 "$OUT/pytest.txt"

    echo "== bench/distributed_frames.py =="
    worlds="1"
    [ "$gpus" -ge 2 ] && worlds="1 $gpus"
    for n in $worlds; do
        timeout 180 python3 -m torch.distributed.run --standalone --nproc-per-node "$n" bench/distributed_frames.py \
            --out "$OUT/frames-$n.json" >"$OUT/frames-$n.log" 2>&1 || { status=1; tail -20 "$OUT/frames-$n.log"; }
    done
    python3 bench/distributed_frames.py --table "$OUT"/frames-*.json | tee "$OUT/frames.md"

    echo "== examples/motion_study/mlem_distributed.py --preset full =="
    for n in $worlds; do
        timeout 240 python3 -m torch.distributed.run --standalone --nproc-per-node "$n" \
            examples/motion_study/mlem_distributed.py --preset full --device cuda --matrix .study/astra-128-180.npz \
            --out "/tmp/mlem-$n" >"$OUT/mlem-$n.log" 2>&1 || status=1
        grep -v Warning "$OUT/mlem-$n.log" | tail -4
        cp "/tmp/mlem-$n/results.json" "$OUT/mlem-$n.json" 2>/dev/null
    done
    if [ "$gpus" -ge 2 ]; then
        python3 - "/tmp/mlem-1/image.npy" "/tmp/mlem-$gpus/image.npy" <<'PY' | tee "$OUT/images.txt" || status=1
import sys
import numpy as np
a, b = (np.load(p) for p in sys.argv[1:])
d = float(np.abs(a - b).max() / np.abs(a).max())
print(f"the image of {sys.argv[2].split('-')[-1].split('/')[0]} GPUs against 1: max |difference| / max = {d:.2e}")
sys.exit(0 if d <= 1e-4 and np.isfinite(b).all() else 1)
PY
    fi
    exit $status
)
