#: wheel                   CI's wheel from .whl/, no build: test_gpu.py and python_torch.py on nvcc's and on NVRTC's kernels
# The wheel CI builds (python -m build, retagged py3-none, auditwheel repair),
# made on the development machine and carried in .whl/, installed beside the
# machine's torch, CuPy and nvidia-cuda-nvrtc with Dask's wheels.
# python/tests/test_gpu.py against it on nvcc's kernels and again with every
# context on NVRTC's (PETBLUR_CUDA_KERNELS=nvrtc, an empty cache), and
# bench/python_torch.py (the paper's eight scenarios through the installed
# package, CUDA events) on each. Back through $OUT: machine.txt,
# pytest-builtin.txt, pytest-nvrtc.txt, torch-builtin.md, torch-nvrtc.md.
# (carry .whl)
# shellcheck shell=bash
mode_wheel() (
    site=$(mktemp -d)/site
    python3 -m pip install -q --no-deps --no-index --target "$site" .whl/petblur-*-py3-none-manylinux*.whl \
        .whl/dask-*.whl .whl/distributed-*.whl .whl/toolz-*.whl .whl/partd-*.whl .whl/locket-*.whl \
        .whl/sortedcontainers-*.whl .whl/tblib-*.whl .whl/zict-*.whl .whl/msgpack-*.whl .whl/tornado-*.whl \
        .whl/psutil-*.whl .whl/click-*.whl .whl/pyyaml-*.whl .whl/cloudpickle-*.whl .whl/fsspec-*.whl 2>&1 | tail -3
    export PYTHONPATH=$site
    write_machine "$OUT/machine.txt" <<<"wheel: $(find .whl -maxdepth 1 -name 'petblur-*.whl' -printf '%f\n')"
    root=$PWD
    cd /tmp || exit 1
    python3 -c 'import petblur, os; print("installed:", petblur.__file__); print("NVRTC:", os.environ.get("PETBLUR_NVRTC_LIBRARY")); print(petblur.backends())' |
        tee -a "$OUT/machine.txt"
    status=0
    for k in builtin nvrtc; do
        echo "== $k: test_gpu.py, python_torch.py =="
        PETBLUR_CACHE_DIR=$(mktemp -d)/cache
        export PETBLUR_CUDA_KERNELS=$k PETBLUR_CACHE_DIR
        timeout 300 python3 -m pytest -v -p no:cacheprovider "$root/python/tests/test_gpu.py" >"$OUT/pytest-$k.txt" 2>&1 ||
            status=1
        tail -3 "$OUT/pytest-$k.txt"
        timeout 240 python3 "$root/bench/python_torch.py" --runs 20 --out "/tmp/torch-$k.csv" >"$OUT/torch-$k.md" 2>&1 ||
            status=1
        tail -2 "$OUT/torch-$k.md"
    done
    python3 - /tmp/torch-builtin.csv /tmp/torch-nvrtc.csv <<'PY' | tee -a "$OUT/torch-nvrtc.md"
import csv, sys
a, b = ([r for r in csv.DictReader(open(p))] for p in sys.argv[1:])
worst = max(abs(float(y["kernel_ms"]) / float(x["kernel_ms"]) - 1) for x, y in zip(a, b))
print(f"NVRTC's against nvcc's kernels through the wheel: C kernel ms within {100 * worst:.1f} % over "
      f"{len(a)} rows (8 scenarios, forward and adjoint, C and F order)")
PY
    exit $status
)
