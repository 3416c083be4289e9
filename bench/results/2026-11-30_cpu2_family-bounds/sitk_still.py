import sys, numpy as np, nibabel as nib, SimpleITK as sitk
img = nib.load(sys.argv[1]); data = img.get_fdata(dtype=np.float32); A = img.affine
ref_i = int(sys.argv[2]); metric = sys.argv[3]
sitk.ProcessObject.SetGlobalDefaultNumberOfThreads(1)
def to_sitk(v):
    s = sitk.GetImageFromArray(np.ascontiguousarray(v.transpose(2, 1, 0)))
    vox = np.linalg.norm(A[:3, :3], axis=0); s.SetSpacing([float(x) for x in vox]); return s
fixed = to_sitk(data[..., ref_i])
vox = np.linalg.norm(A[:3, :3], axis=0); shape = np.array(data.shape[:3])
c = 0.5 * (shape - 1) * vox
rng = np.random.default_rng(0); pts = c + rng.normal(size=(2000, 3)) * 0.25 * shape * vox
out = []
for k in range(data.shape[3]):
    mov = to_sitk(data[..., k])
    R = sitk.ImageRegistrationMethod()
    if metric == "mi": R.SetMetricAsMattesMutualInformation(32)
    else: R.SetMetricAsCorrelation()
    R.SetMetricSamplingStrategy(R.NONE)
    R.SetInterpolator(sitk.sitkLinear)
    R.SetOptimizerAsRegularStepGradientDescent(1.0, 1e-4, 300, relaxationFactor=0.6)
    R.SetOptimizerScalesFromPhysicalShift()
    R.SetShrinkFactorsPerLevel([4, 2, 1]); R.SetSmoothingSigmasPerLevel([2, 1, 0]); R.SmoothingSigmasAreSpecifiedInPhysicalUnitsOn()
    tx = sitk.Euler3DTransform(); tx.SetCenter([float(x) for x in c]); R.SetInitialTransform(tx, inPlace=True)
    R.Execute(fixed, mov)
    d = np.array([np.linalg.norm(np.array(tx.TransformPoint([float(x) for x in p])) - p) for p in pts[:400]])
    out.append(d.mean())
print(metric, "ref", ref_i, "mean %.3f" % np.mean(out), " ".join("%.2f" % x for x in out), flush=True)
