"""Displacement-field files as registration tools write them, read with
nibabel into what FieldMotion takes: world (RAS+) displacements in mm on the
file's grid, and that grid's voxel-to-world affine.

Three conventions, told apart by the NIfTI header where it says, never
guessed (a field read in the wrong one moves the image the wrong way, which
nothing downstream could notice):
- 'nifti': NIFTI_INTENT_DISPVECT (1006), displacements in world mm, RAS as
  the NIfTI standard has its world. ITK reads such a file by flipping x and
  y into LPS, which confirms the frame.
- 'niftyreg': NIFTI_INTENT_VECTOR (1007) named 'NREG_TRANS', intent_p1 the
  NREG_TRANS_TYPE of NiftyReg's reg-lib (Maths.hpp): 0 a deformation (world
  positions, RAS), 1 a displacement (position less the voxel's own world
  position). reg_transform -def / -disp write them; SIRF's NiftyReg-based
  registrations write the same intent_p1, not always the name.
- 'itk' (ITK, SimpleITK, ANTs): 1007 with no name, displacements in ITK's
  physical frame, LPS: x and y negated against RAS. ITK's NiftiImageIO
  writes every vector image so, so the file cannot say it is ITK's.
"""

import os
import pathlib
import warnings

import numpy as np

from .errors import ArgumentError, Error, FileContentError, FileError

INTENT_DISPVECT, INTENT_VECTOR = 1006, 1007
NIFTYREG_NAME = "NREG_TRANS"
# NREG_TRANS_TYPE (NiftyReg reg-lib/cpu/Maths.hpp), kept in intent_p1.
NIFTYREG_TYPES = {0: "deformation", 1: "displacement", 2: "cubic B-spline control-point grid",
                  3: "deformation velocity field", 4: "displacement velocity field",
                  5: "B-spline velocity grid", 6: "linear B-spline control-point grid"}
CONVENTIONS = {"nifti": "nifti", "niftyreg": "niftyreg", "sirf": "niftyreg", "itk": "itk", "ants": "itk",
               "simpleitk": "itk"}
_LPS = np.array([-1.0, -1.0, 1.0])  # RAS <-> LPS, either way
_FIX = ("give convention='itk' for ITK, SimpleITK or ANTs (LPS displacements), convention='niftyreg' for "
        "NiftyReg or SIRF (intent_p1 0 a deformation, 1 a displacement) or convention='nifti' for RAS "
        "displacements")


def convention_name(convention):
    """The canonical name of a convention= value (None stays None)."""
    if convention is None:
        return None
    key = convention.lower() if isinstance(convention, str) else None
    if key not in CONVENTIONS:
        raise ArgumentError(f"convention {convention!r}: give None (read it from the file), 'nifti', 'niftyreg' "
                            "(or 'sirf'), or 'itk' (or 'ants', 'simpleitk')")
    return CONVENTIONS[key]


def _nibabel():
    try:
        import nibabel
    except ImportError:
        raise Error("reading field files needs nibabel: pip install nibabel") from None
    return nibabel


def read_csv(path):
    """(times, paths) of a `time,path` CSV: a header line `time,path`, then
    one field a line, its time in seconds, a comma, its path (the rest of
    the line, blanks trimmed; relative to the CSV's folder). Blank lines are
    skipped."""
    path = pathlib.Path(os.fspath(path))
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise FileError(f"{path}: cannot read the field list ({e})") from None
    lines = [(n, line.strip()) for n, line in enumerate(text.splitlines(), 1) if line.strip()]
    if not lines or [p.strip().lower() for p in lines[0][1].split(",")] != ["time", "path"]:
        first = lines[0][1] if lines else "nothing"
        raise FileContentError(f"{path}:{lines[0][0] if lines else 1}: the header must be 'time,path', not {first!r}")
    times, paths = [], []
    for n, line in lines[1:]:
        t, comma, p = line.partition(",")
        p = p.strip()
        if not comma or not p:
            raise FileContentError(f"{path}:{n}: give 'time,path' (seconds, a comma, the field's file), not {line!r}")
        try:
            value = float(t)
        except ValueError:
            value = None
        if value is None or not np.isfinite(value):
            raise FileContentError(f"{path}:{n}: the time {t.strip()!r} is not a finite number of seconds")
        if times and value <= times[-1]:
            raise FileContentError(f"{path}:{n}: time {value:g} s does not come after {times[-1]:g} s; the fields "
                                   "must be listed in increasing time")
        times.append(value)
        paths.append(path.parent / p)
    if len(times) < 2:
        raise FileContentError(f"{path}: {len(times)} field(s) listed; a motion needs two at least (the same file "
                               "twice, at two times, is a still warp)")
    return times, paths


def world_affine(header, path):
    """The grid's voxel-to-world 4x4 as NiftyReg and ITK take it (through
    nifti1_io): the sform where its code is set, else the qform, else a
    diagonal of the voxel sizes with voxel 0 at the origin. nibabel's own
    fallback centres the grid instead, which would misplace a field that a
    tool computed by nifti1_io's rule: so that one is not used, and warned
    of."""
    try:
        sform, scode = header.get_sform(coded=True)
        qform, qcode = header.get_qform(coded=True)
    except Exception as e:  # a quaternion nibabel cannot complete, and the like
        raise FileContentError(f"{path}: its sform/qform make no voxel-to-world matrix ({type(e).__name__}: {e})") \
            from None
    if sform is not None and scode > 0:
        a = sform
    elif qform is not None and qcode > 0:
        a = qform
    else:
        zooms = np.array(header["pixdim"][1:4], dtype=np.float64)
        zooms[(zooms == 0) | ~np.isfinite(zooms)] = 1.0  # as nifti1_io repairs pixdim
        a = np.diag(np.append(zooms, 1.0))
        warnings.warn(f"{path}: neither sform nor qform places the field's grid in the world; taken as NiftyReg "
                      "and ITK take it, voxel (0, 0, 0) at the origin and the voxel sizes along x, y, z: give the "
                      "operator an image affine in that same world", UserWarning, stacklevel=4)
    a = np.array(a, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        raise FileContentError(f"{path}: its voxel-to-world matrix (sform/qform) is not finite")
    m = a[:3, :3]
    if abs(np.linalg.det(m)) < 1e-12 * max(1.0, np.abs(m).max()) ** 3:
        raise FileContentError(f"{path}: its voxel-to-world matrix (sform/qform) is singular, so the field's grid "
                               "has no place in the world; fix the file's header")
    return a


def _file_convention(header, path, convention):
    """'nifti', 'itk', 'niftyreg-def' or 'niftyreg-disp' for one file."""
    code = int(header["intent_code"])
    name = np.asarray(header["intent_name"]).item()
    name = (name.decode("latin-1") if isinstance(name, bytes) else str(name)).split("\0")[0].strip()
    p1 = float(header["intent_p1"])
    if convention is None:
        if code == INTENT_DISPVECT:
            convention = "nifti"
        elif code == INTENT_VECTOR and name == NIFTYREG_NAME:
            convention = "niftyreg"
        elif code == INTENT_VECTOR:
            raise ArgumentError(f"{path} holds a vector field (NIfTI intent 1007) that does not say its "
                                f"convention: ITK, SimpleITK and ANTs write theirs so, in LPS, SIRF in RAS; {_FIX}")
        else:
            raise ArgumentError(f"{path} is no displacement field by its header (NIfTI intent {code}, not 1006 "
                                f"DISPVECT, nor 1007 VECTOR); if it holds one, {_FIX}")
    if convention != "niftyreg":
        return convention
    kind = NIFTYREG_TYPES.get(int(p1)) if p1 == int(p1) else None
    if kind in ("deformation", "displacement"):
        return "niftyreg-def" if kind == "deformation" else "niftyreg-disp"
    what = f"a NiftyReg {kind}" if kind else f"intent_p1 {p1:g}, no NiftyReg field type"
    raise FileContentError(f"{path}: {what}, not a dense deformation or displacement field (intent_p1 0 or 1); "
                           "NiftyReg's reg_transform -ref IMAGE -disp (or -def) TRANSFORM FIELD makes one")


def _field_values(img, path):
    """The file's vectors as float64 (nx, ny, nz, 3)."""
    shape = img.shape
    if len(shape) == 5 and shape[3] == 1 and shape[4] == 3:
        shape = shape[:3] + (3,)
    if len(shape) != 4 or shape[3] != 3:
        raise FileContentError(f"{path} has shape {img.shape}; a 3-D displacement field is (nx, ny, nz, 1, 3) as "
                               "NIfTI stores it (or (nx, ny, nz, 3)): one field a file, three components")
    try:
        data = np.asarray(img.dataobj)
    except Exception as e:  # truncated, unzippable or odd data: nibabel raises many kinds
        raise FileError(f"{path}: cannot read its data ({type(e).__name__}: {e})") from None
    if not np.issubdtype(data.dtype, np.number) or np.iscomplexobj(data):
        raise FileContentError(f"{path} holds {data.dtype} values; a displacement field holds real numbers (mm)")
    data = data.reshape(shape).astype(np.float64, copy=False)
    bad = ~np.isfinite(data)
    if bad.any():
        first = tuple(int(i) for i in np.argwhere(bad)[0][:3])
        raise FileContentError(f"{path}: {int(bad.any(axis=-1).sum())} voxel(s) hold NaN or infinite vectors, the "
                               f"first at voxel {first}; a field must be finite everywhere")
    return data


def _ras_displacements(data, convention, affine):
    if convention == "itk":
        return data * _LPS
    if convention == "niftyreg-def":  # positions: less each voxel's own world position
        ijk = np.indices(data.shape[:3], dtype=np.float64)
        return data - (np.moveaxis(ijk, 0, -1) @ affine[:3, :3].T + affine[:3, 3])
    return data


def read_fields(paths, convention=None):
    """(displacements (K, nx, ny, nz, 3) float32 RAS mm, affine 4x4) of the
    files at paths, which must share one grid."""
    nib = _nibabel()
    convention = convention_name(convention)
    out, affine, shape, first, seen = None, None, None, None, {}
    for k, path in enumerate(paths):
        path = os.fspath(path)
        key = os.path.realpath(path)
        if key in seen:  # a file listed twice (a still warp) is read once
            out[k] = out[seen[key]]
            continue
        try:
            img = nib.load(path)
        except FileNotFoundError:
            raise FileError(f"{path}: no such field file") from None
        except Exception as e:  # not NIfTI, truncated header: nibabel raises many kinds
            raise FileError(f"{path}: cannot be read as NIfTI ({type(e).__name__}: {e})") from None
        if not isinstance(img, (nib.Nifti1Image, nib.Nifti2Image)):
            raise FileError(f"{path} is a {type(img).__name__}, not NIfTI; fields are read from NIfTI files "
                            "(SimpleITK converts others: sitk.WriteImage(sitk.ReadImage(f), 'field.nii.gz'))")
        kind = _file_convention(img.header, path, convention)
        a = world_affine(img.header, path)
        data = _field_values(img, path)
        if out is None:
            affine, shape, first = a, data.shape[:3], path
            out = np.empty((len(paths),) + data.shape, dtype=np.float32)
        elif data.shape[:3] != shape or not np.allclose(a, affine, rtol=0, atol=1e-4 * max(1.0, np.abs(affine).max())):
            # How far apart the two grids' corners lie says which is off, and how much.
            ends = np.array(shape) - 1
            corners = np.array([[i, j, k, 1] for i in (0, ends[0]) for j in (0, ends[1]) for k in (0, ends[2])])
            apart = np.abs(corners @ (a - affine).T).max()
            how = (f"{data.shape[:3]} voxels against {shape}" if data.shape[:3] != shape else
                   f"its affine places the grid up to {apart:.3g} mm from {os.path.basename(first)}'s")
            raise FileContentError(f"{path} lies on another grid than {first}: {how}; all fields must share one grid: "
                                   "resample them onto one (NiftyReg's reg_transform -ref, SimpleITK's "
                                   "TransformToDisplacementField)")
        out[k] = _ras_displacements(data, kind, a)
        seen[key] = k
    return out, affine
