"""FieldMotion.from_files against SimpleITK's resampling, an implementation
written apart from petblur: fresh random smooth fields on grids with random
oblique and flipped affines, written as NIfTI (intent 1006), NiftyReg
(deformation and displacement) and ITK (SimpleITK's own writer) write them,
read back, and a still warp of a random sharp object blurred with them
(method 'rm', filter 'exact': each voxel reads the object trilinearly at
r + D(r), as a linear resampler does) on an image grid placed otherwise than
the field's. The seed is printed; PETBLUR_TEST_SEED replays one. Also here:
the files that must be refused, with the message that says why."""

import os
import re

import nibabel as nib
import numpy as np
import pytest
import SimpleITK as sitk  # the test extra's: a missing one fails, not skips, the comparison
from scipy import ndimage

import petblur

LPS = np.diag([-1.0, -1.0, 1.0, 1.0])  # RAS <-> LPS for affines, either way
ORIENTATIONS = {"ras": np.eye(3), "lps": np.diag([-1.0, -1.0, 1.0]), "las": np.diag([-1.0, 1.0, 1.0])}


def rotation(rng, max_degrees):
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    a = np.radians(rng.uniform(-max_degrees, max_degrees))
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(a) * k + (1 - np.cos(a)) * k @ k


def oblique_affine(rng, orientation, shape, zooms, centre):
    """A voxel-to-world (RAS) 4x4 whose grid is centred on centre: the
    orientation's axes turned by up to 25 degrees, rounded to float32 as
    the NIfTI header keeps it."""
    a = np.eye(4)
    a[:3, :3] = ORIENTATIONS[orientation] @ rotation(rng, 25) * zooms
    a[:3, 3] = centre - a[:3, :3] @ ((np.array(shape) - 1) / 2)
    return a.astype(np.float32).astype(np.float64)


def world(affine, shape):
    ijk = np.moveaxis(np.indices(shape, dtype=np.float64), 0, -1)
    return ijk @ affine[:3, :3].T + affine[:3, 3]


def smooth_displacement(rng, points):
    """RAS mm at world points: a few plane waves of 50 to 90 mm, each
    component up to about 3 mm; gentle enough never to fold."""
    d = np.zeros(points.shape)
    for _ in range(3):
        k = rng.normal(size=3)
        k *= 2 * np.pi / rng.uniform(50, 90) / np.linalg.norm(k)
        d += rng.uniform(-1, 1, size=3) * np.sin(points @ k + rng.uniform(0, 2 * np.pi))[..., None]
    return d


def sharp_object(rng, shape):
    """Random boxes and balls of random heights, zero within 4 voxels of
    the faces (so that the two resamplers' edge rules meet only zeros)."""
    x = np.zeros(shape)
    ijk = np.moveaxis(np.indices(shape, dtype=np.float64), 0, -1)
    n = np.array(shape)
    for _ in range(6):
        lo = rng.uniform(4, n - 12)
        hi = np.minimum(lo + rng.uniform(3, 12, size=3), n - 5)
        if rng.random() < 0.5:
            inside = np.all((ijk >= lo) & (ijk <= hi), axis=-1)
        else:
            centre, r = (lo + hi) / 2, rng.uniform(2, 5)
            inside = np.linalg.norm(ijk - centre, axis=-1) <= r
        x[inside] += rng.uniform(1, 5)
    return x.astype(np.float32)


def sitk_image(array, affine, vector=False):
    """array [x, y, z(, 3)] as a SimpleITK image placed by the RAS affine
    (ITK's physical space is LPS: flip the affine's first two rows)."""
    a = LPS @ affine
    spacing = np.linalg.norm(a[:3, :3], axis=0)
    img = sitk.GetImageFromArray(np.ascontiguousarray(np.swapaxes(array, 0, 2)), isVector=vector)
    img.SetSpacing(spacing.tolist())
    img.SetDirection((a[:3, :3] / spacing).ravel().tolist())
    img.SetOrigin(a[:3, 3].tolist())
    return img


def write_field(path, kind, d_ras, affine):
    """d_ras (nx, ny, nz, 3) float32 written as the tool of kind writes it."""
    if kind == "itk":  # SimpleITK's own writer: LPS vectors, intent 1007 and no name
        sitk.WriteImage(sitk_image(d_ras * np.array([-1, -1, 1], np.float32), affine, vector=True), str(path))
        return
    data = d_ras
    if kind == "niftyreg-def":  # a deformation holds world positions
        data = (world(affine, d_ras.shape[:3]) + d_ras).astype(np.float32)
    img = nib.Nifti1Image(data[:, :, :, None, :], affine)
    img.header.set_qform(affine, code=1)
    img.header.set_sform(affine, code=1)
    if kind == "nifti":
        img.header.set_intent(1006)
    else:
        img.header.set_intent("vector", name="NREG_TRANS")
        img.header["intent_p1"] = 0 if kind == "niftyreg-def" else 1
    nib.save(img, str(path))


def compare(y, ref, mask):
    diff = (y - ref)[mask]
    rms = 100 * np.sqrt(np.mean(diff ** 2) / np.mean(ref[mask] ** 2))
    worst = 100 * np.abs(diff).max() / np.abs(ref[mask]).max()
    return rms, worst


@pytest.mark.parametrize("field_orientation", ["lps", "ras"])
@pytest.mark.parametrize("kind", ["nifti", "niftyreg-def", "niftyreg-disp", "itk"])
def test_still_warp_matches_simpleitk(kind, field_orientation, device, rng, tmp_path):
    shape = tuple(int(n) for n in rng.integers(26, 37, size=3))
    zooms = rng.uniform(1.8, 3.2, size=3)
    centre = rng.uniform(-40, 40, size=3)
    image_orientation = str(rng.choice(list(ORIENTATIONS)))
    image_affine = oblique_affine(rng, image_orientation, shape, zooms, centre)
    # The field's grid: coarser, turned otherwise, covering most of the image.
    f_zooms = rng.uniform(3.5, 6.0, size=3)
    diagonal = np.linalg.norm(np.array(shape) * zooms)
    f_shape = tuple(int(n) for n in np.ceil(0.85 * diagonal / f_zooms))
    field_affine = oblique_affine(rng, field_orientation, f_shape, f_zooms, centre + rng.uniform(-5, 5, size=3))
    d_ras = smooth_displacement(rng, world(field_affine, f_shape)).astype(np.float32)
    x = sharp_object(rng, shape)
    print(f"{kind}: field {f_shape} {field_orientation}, image {shape} {image_orientation}")

    path = tmp_path / "field.nii.gz"
    write_field(path, kind, d_ras, field_affine)
    convention = "itk" if kind == "itk" else None  # ITK's files cannot say so: the caller must
    motion = petblur.FieldMotion.from_files([path, path], times=[0.0, 1.0], convention=convention)
    op = petblur.BlurOperator(shape, np.linalg.norm(image_affine[:3, :3], axis=0), motion,
                              frame=(0.0, 1.0), method="rm", filter="exact", affine=image_affine, device=device)
    y = np.asarray(op(x), dtype=np.float64)

    field = sitk.Cast(sitk_image(d_ras.astype(np.float64) * np.array([-1, -1, 1]), field_affine, vector=True),
                      sitk.sitkVectorFloat64)
    obj = sitk_image(x.astype(np.float64), image_affine)
    ref = sitk.Resample(obj, obj, sitk.DisplacementFieldTransform(field), sitk.sitkLinear, 0.0, sitk.sitkFloat64)
    ref = np.swapaxes(sitk.GetArrayFromImage(ref), 0, 2)

    # Compare where both interpolate the field alike: ITK gives a point beyond
    # half a voxel outside the field's grid no displacement at all, petblur
    # holds the edge values beyond the outer voxel centres. So voxels whose
    # centre falls within the field's outer voxel centres, less a quarter
    # voxel; and whose displaced point lies inside the image's outer centres
    # (past them ITK holds the edge value for half a voxel, petblur reads 0).
    centres = world(image_affine, shape)
    f_index = (centres - field_affine[:3, 3]) @ np.linalg.inv(field_affine[:3, :3]).T
    inside_field = np.all((f_index >= 0.25) & (f_index <= np.array(f_shape) - 1.25), axis=-1)
    d_at = np.stack([ndimage.map_coordinates(d_ras[..., c], np.moveaxis(f_index, -1, 0), order=1, mode="nearest")
                     for c in range(3)], axis=-1)
    o_index = (centres + d_at - image_affine[:3, 3]) @ np.linalg.inv(image_affine[:3, :3]).T
    inside_image = np.all((o_index >= 0.25) & (o_index <= np.array(shape) - 1.25), axis=-1)
    mask = inside_field & inside_image
    assert mask.mean() > 0.5, f"only {mask.mean():.0%} of the voxels compared"
    assert np.count_nonzero(ref[mask]) > 500
    moved = compare(x.astype(np.float64), ref, mask)
    rms, worst = compare(y, ref, mask)
    print(f"{kind} on {device}: relative RMS {rms:.2e} %, max {worst:.2e} % over {mask.sum()} voxels "
          f"({mask.mean():.0%}); the warp itself moves {moved[0]:.0f} % RMS")
    assert moved[0] > 5, "the warp hardly moves the object: the comparison would show nothing"
    # Measured (host and PoCL): RMS 1.5e-6 to 5e-5 %, max 3e-6 to 1.4e-4 %: float32
    # fields and sforms, PoCL's float arithmetic. A sign or half-voxel slip
    # costs percents.
    assert rms < 5e-4 and worst < 2e-3


def field_file(tmp_path, rng, name, shape=(7, 6, 5), affine=None, kind="nifti"):
    """A small random field file; returns (path, RAS displacements, affine)."""
    if affine is None:
        affine = oblique_affine(rng, str(rng.choice(list(ORIENTATIONS))), shape, rng.uniform(2, 5, size=3),
                                rng.uniform(-20, 20, size=3))
    d = rng.uniform(-3, 3, size=shape + (3,)).astype(np.float32)
    path = tmp_path / name
    write_field(path, kind, d, affine)
    return path, d, affine


@pytest.mark.parametrize("kind", ["nifti", "niftyreg-def", "niftyreg-disp", "itk"])
def test_reader_gives_ras_displacements(kind, rng, tmp_path):
    """Each convention read back to the RAS displacements and the grid's
    affine it was written from; the same files through a CSV."""
    written = [field_file(tmp_path, rng, f"f{i}.nii.gz", kind=kind) for i in range(1)]
    path, d, affine = written[0]
    path2 = tmp_path / "g.nii.gz"
    d2 = rng.uniform(-3, 3, size=d.shape).astype(np.float32)
    write_field(path2, kind, d2, affine)
    convention = "itk" if kind == "itk" else None
    m = petblur.FieldMotion.from_files([path, path2], times=[0, 2.5], convention=convention)
    # A deformation holds positions of about 100 mm in float32: its
    # displacements keep their ulp (1e-5 mm).
    tol = 2e-5 if kind == "niftyreg-def" else 0
    np.testing.assert_allclose(m.displacements(), np.stack([d, d2]), rtol=0, atol=tol)
    np.testing.assert_allclose(m.affine, affine, rtol=0, atol=1e-4)
    assert m.times.tolist() == [0, 2.5]
    (tmp_path / "sub").mkdir()
    csv = tmp_path / "sub" / "fields.csv"
    up = os.pardir + os.sep  # the fields beside the CSV's folder, blanks and an empty line around them
    csv.write_text(f"time,path\n0,{up}f0.nii.gz\n\n 2.5 , {up}g.nii.gz \n")
    c = petblur.FieldMotion.from_files(csv, convention=convention)
    np.testing.assert_array_equal(c.displacements(), m.displacements())
    assert c.times.tolist() == [0, 2.5]


def test_convention_overrides_the_header(rng, tmp_path):
    """convention= wins over the intent: a DISPVECT file read as ITK's has
    x and y negated; an ITK file read as NIfTI's keeps them; a 4-D file
    (nx, ny, nz, 3) reads as its 5-D form."""
    path, d, _ = field_file(tmp_path, rng, "f.nii.gz", kind="nifti")
    for convention in ("itk", "ANTs", "simpleitk"):
        m = petblur.FieldMotion.from_files([path, path], [0, 1], convention=convention)
        np.testing.assert_array_equal(m.displacements()[0], d * np.array([-1, -1, 1], np.float32))
    path, d, _ = field_file(tmp_path, rng, "i.nii.gz", kind="itk")
    m = petblur.FieldMotion.from_files([path, path], [0, 1], convention="nifti")
    np.testing.assert_array_equal(m.displacements()[1], d * np.array([-1, -1, 1], np.float32))
    img = nib.load(path)
    four = tmp_path / "four.nii"
    nib.save(nib.Nifti1Image(np.asarray(img.dataobj)[:, :, :, 0, :], img.affine, img.header), four)
    m4 = petblur.FieldMotion.from_files([four, four], [0, 1], convention="itk")
    np.testing.assert_array_equal(m4.displacements()[0], d)


def test_unplaced_grid_is_taken_as_niftyreg_takes_it(rng, tmp_path):
    """No sform nor qform: voxel 0 at the origin, the voxel sizes along the
    axes (nifti1_io's rule, which NiftyReg's positions assume), warned."""
    data = rng.uniform(-3, 3, size=(5, 4, 3, 1, 3)).astype(np.float32)
    img = nib.Nifti1Image(data, None)
    img.header.set_zooms((2.0, 3.0, 4.0, 1.0, 1.0))
    img.header.set_intent(1006)
    img.header["sform_code"] = img.header["qform_code"] = 0
    path = tmp_path / "f.nii"
    nib.save(img, path)
    with pytest.warns(UserWarning, match="neither sform nor qform"):
        m = petblur.FieldMotion.from_files([path, path], [0, 1])
    np.testing.assert_array_equal(m.affine, np.diag([2.0, 3.0, 4.0, 1.0]))


def refused(error, match, *args, **kwargs):
    with pytest.raises(error, match=match) as e:
        petblur.FieldMotion.from_files(*args, **kwargs)
    print(e.value)
    return e.value


def test_bad_files_are_refused(rng, tmp_path):
    good, d, affine = field_file(tmp_path, rng, "good.nii.gz")

    d_nan = d.copy()
    i = tuple(int(rng.integers(0, n)) for n in d.shape[:3])
    d_nan[i + (int(rng.integers(0, 3)),)] = rng.choice([np.nan, np.inf, -np.inf])
    nan = tmp_path / "nan.nii.gz"
    write_field(nan, "nifti", d_nan, affine)
    refused(petblur.FileContentError, re.escape("nan.nii.gz: 1 voxel(s) hold NaN or infinite vectors, the first "
                                                f"at voxel {i}"), [good, nan], [0, 1])

    for shape in [(7, 6, 5, 1, 2), (7, 6, 5), (7, 6, 5, 2, 3), (7, 6, 5, 3, 1), (7, 6, 5, 1, 1, 3)]:
        bad = tmp_path / "shape.nii"
        img = nib.Nifti1Image(rng.uniform(size=shape).astype(np.float32), affine)
        img.header.set_intent(1006)
        nib.save(img, bad)
        refused(petblur.FileContentError, rf"shape.nii has shape \({shape[0]}, .*one field a file", [good, bad],
                [0, 1])

    singular = affine.copy()
    singular[:3, int(rng.integers(0, 3))] = 0
    bad = tmp_path / "singular.nii.gz"
    img = nib.Nifti1Image(d[:, :, :, None, :], None)  # a qform cannot hold it: the sform alone
    img.header.set_sform(singular, code=1)
    img.header.set_intent(1006)
    nib.save(img, bad)
    refused(petblur.FileContentError, "singular.nii.gz: its voxel-to-world matrix .* is singular", [bad, bad], [0, 1])
    broken = affine.copy()
    broken[int(rng.integers(0, 3)), int(rng.integers(0, 4))] = rng.choice([np.nan, np.inf])
    img.header.set_sform(broken, code=1)
    nib.save(img, bad)
    refused(petblur.FileContentError, "singular.nii.gz: its voxel-to-world matrix .* is not finite", [bad, bad], [0, 1])

    other = tmp_path / "other.nii.gz"
    write_field(other, "nifti", d[:-1], affine)
    refused(petblur.FileContentError, "other.nii.gz lies on another grid than .*good.nii.gz", [good, other], [0, 1])
    moved = affine.copy()
    moved[:3, 3] += rng.uniform(0.5, 2, size=3)
    write_field(other, "nifti", d, moved)
    refused(petblur.FileContentError, "other.nii.gz lies on another grid", [good, good, other], [0, 1, 2])

    itk, _, _ = field_file(tmp_path, rng, "itk.nii.gz", kind="itk")
    e = refused(petblur.ArgumentError, "itk.nii.gz holds a vector field .*intent 1007.* does not say its convention",
                [itk, itk], [0, 1])
    assert "convention='itk'" in e.message and "convention='nifti'" in e.message
    assert not isinstance(e, petblur.FileError)  # the file is fine: the call must say how to read it

    plain = tmp_path / "plain.nii"
    nib.save(nib.Nifti1Image(d[:, :, :, None, :], affine), plain)
    refused(petblur.ArgumentError, r"plain.nii is no displacement field by its header \(NIfTI intent 0", [plain, plain],
            [0, 1])

    for p1, what in [(2, "cubic B-spline control-point grid"), (4, "displacement velocity field"),
                     (0.5, "intent_p1 0.5")]:
        grid = tmp_path / "cpp.nii.gz"
        img = nib.Nifti1Image(d[:, :, :, None, :], affine)
        img.header.set_intent("vector", name="NREG_TRANS")
        img.header["intent_p1"] = p1
        nib.save(img, grid)
        refused(petblur.FileContentError, f"cpp.nii.gz: .*{what}.*reg_transform", [grid, grid], [0, 1])

    truncated = tmp_path / "truncated.nii.gz"
    truncated.write_bytes(good.read_bytes()[: int(rng.integers(400, good.stat().st_size - 8))])
    refused(petblur.FileError, "truncated.nii.gz: cannot", [truncated, truncated], [0, 1])
    noise = tmp_path / "noise.nii"
    noise.write_bytes(rng.bytes(int(rng.integers(0, 2000))))
    refused(petblur.FileError, "noise.nii: cannot be read as NIfTI", [noise, noise], [0, 1])
    refused(petblur.FileError, "missing.nii.gz: no such field file", [good, tmp_path / "missing.nii.gz"], [0, 1])


def test_bad_calls_and_lists_are_refused(rng, tmp_path):
    good, _, _ = field_file(tmp_path, rng, "good.nii.gz")
    refused(petblur.ArgumentError, "convention 'fsl'", [good, good], [0, 1], convention="fsl")
    refused(petblur.ArgumentError, "times= is needed", [good, good])
    refused(petblur.ArgumentError, "3 times for 2 field files", [good, good], [0, 1, 2])
    refused(petblur.ArgumentError, "increasing", [good, good], [1, 1])
    refused(petblur.ArgumentError, "increasing", [good], [0])
    refused(petblur.ArgumentError, "increasing", [good, good], [0, np.nan])
    refused(petblur.ArgumentError, "one file is one field", good)
    csv = tmp_path / "f.csv"
    refused(petblur.ArgumentError, "without times=", csv, [0, 1])
    for text, match in [("t,path\n0,good.nii.gz\n", "f.csv:1: the header must be 'time,path'"),
                        ("time,path\n0,good.nii.gz\n1 good.nii.gz\n", "f.csv:3: give 'time,path'"),
                        ("time,path\n0,good.nii.gz\nnan,good.nii.gz\n", "f.csv:3: the time 'nan' is not a finite"),
                        ("time,path\n1,good.nii.gz\n\n0.5,good.nii.gz\n", "f.csv:4: time 0.5 s does not come after"),
                        ("time,path\n1,good.nii.gz\n", "f.csv: 1 field"),
                        ("time,path\n0,good.nii.gz\n1,\n", "f.csv:3: give 'time,path'")]:
        csv.write_text(text)
        refused(petblur.FileContentError, match, csv)
    refused(petblur.FileError, "cannot read the field list", tmp_path / "none.csv")
