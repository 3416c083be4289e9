#: kernels                 build (CUDA, OpenCL); suites on CUDA, NVIDIA OpenCL, PoCL; demo; CUDA against OpenCL; pb_bench and pb_frames timings
# Every question about a kernel change short of the paper's tables: the host
# suite, the cuda suite, the opencl suite on NVIDIA's OpenCL and on PoCL, how
# far CUDA is from PoCL and from NVIDIA's OpenCL on the same inputs, the demo,
# the benchmark of every method on a 256^3 volume for the paper's eight
# motions on CUDA (CUDA events) and on NVIDIA's OpenCL (profiling events), and
# twenty dynamic frames in one call against one call per frame
# (bench/pb_frames). Fits the device tool's ten minutes. Back through $OUT:
# tables.md, tests.txt, demo-cuda.png and logs.tar.gz with everything else.
# (carry .device)
# shellcheck shell=bash disable=SC2154 # meson and the helpers: bench/gpu/lib.sh
mode_kernels() (
    LOG=${kernels_log:-$(mktemp -d)/logs}
    mkdir -p "$LOG"
    write_machine "$LOG/machine.txt" </dev/null
    BUILD_LOGS=$LOG build_gpu
    # Registers and spills of the CUDA kernels, for the record.
    nvcc -arch=sm_90 -O3 -std=c++17 -Xptxas -v -c cuda/pb_kernels.cu -o /dev/null 2>&1 |
        grep -E 'entry function|registers' >"$LOG/cuda-registers.txt"

    # Each OpenCL platform on its own, through a vendor folder of its own.
    nv=$(icd_folder nvidia)
    pocl=$(icd_folder pocl)
    status=0
    platform_suites() { # name, vendor folder, suites...
        local name=$1 vendors=$2 s
        shift 2
        echo "== tests: $name =="
        local args=()
        for s in "$@"; do args+=(--suite "$s"); done
        OCL_ICD_VENDORS=$vendors "${meson[@]}" test -C build-gpu --no-rebuild --print-errorlogs "${args[@]}" \
            >"$LOG/test-$name.log" 2>&1 || status=1
        cp build-gpu/meson-logs/testlog.txt "$LOG/testlog-$name.txt"
        {
            echo "== $name"
            grep -E '^ *[0-9]+/[0-9]+ |^(Ok|Fail|Skipped):' "$LOG/test-$name.log"
            grep -h 'largest relative difference\|hardware weights\|largest relative mismatch\|voxel off' \
                build-gpu/meson-logs/testlog.txt | sed "s/^/$name: /"
        } | tee -a "$OUT/tests.txt"
    }
    OCL_ICD_VENDORS="$nv:$pocl" ./build-gpu/src/cli/petblur devices
    platform_suites host "$pocl" host
    platform_suites cuda "$pocl" cuda
    platform_suites nvidia-opencl "$nv" opencl
    platform_suites pocl "$pocl" opencl

    echo "== the main job: petblur demo on CUDA and NVIDIA OpenCL (brain phantom, full 128x128x64) =="
    for d in cuda opencl; do
        OCL_ICD_VENDORS=$nv ./build-gpu/src/cli/petblur demo --device $d --size 128 --out-dir "$LOG/demo-$d" \
            2>&1 | tee "$LOG/demo-$d.txt" || status=1
        rm -f "$LOG/demo-$d"/*.nii.gz
    done
    cp "$LOG/demo-cuda/demo.png" "$OUT/demo-cuda.png" 2>/dev/null

    echo "== CUDA against PoCL and against NVIDIA OpenCL, same inputs =="
    for platform in pocl nvidia; do
        echo "## CUDA (A) against $platform OpenCL (B)" | tee -a "$LOG/compare.txt"
        vendors=$pocl
        [ $platform = nvidia ] && vendors=$nv
        OCL_ICD_VENDORS=$vendors ./build-gpu/bench/pb_compare --size 64 cuda opencl:0 |
            tee -a "$LOG/compare.txt" || status=1
    done

    echo "== benchmark: CUDA, 256^3, paper scenarios 1-8 =="
    ./build-gpu/bench/pb_bench --device cuda --size 256 --runs 20 --ref-runs 0 \
        --label cuda --csv "$LOG/bench-cuda.csv" | tee "$LOG/bench-cuda.txt" || status=1
    echo "== benchmark: NVIDIA OpenCL, 256^3, paper scenarios 1-8 =="
    OCL_ICD_VENDORS=$nv ./build-gpu/bench/pb_bench --device opencl --size 256 --runs 20 --ref-runs 0 \
        --label nvidia-opencl --csv "$LOG/bench-nvidia-opencl.csv" | tee "$LOG/bench-nvidia-opencl.txt" || status=1
    echo "== benchmark: PoCL on the GPU machine's CPU, 128^3, scenario 2 =="
    OCL_ICD_VENDORS=$pocl ./build-gpu/bench/pb_bench --device opencl --size 128 --runs 5 --ref-runs 0 \
        --scenario 2 --label pocl-cpu --csv "$LOG/bench-pocl.csv" | tee "$LOG/bench-pocl.txt" || status=1

    echo "== dynamic frames: 20 frames of 256^3, a 30 Hz track, one call against one call per frame =="
    for d in cuda opencl; do
        OCL_ICD_VENDORS=$nv ./build-gpu/bench/pb_frames --device $d --size 256 --frames 20 --runs 5 \
            --label $d --csv "$LOG/frames-$d.csv" 2>&1 | tee "$LOG/frames-$d.txt" || status=1
    done

    # The tables and logs come back even if a paper run after this (mode all)
    # runs past the device's time limit.
    {
        sed 's/^/    /' "$LOG/machine.txt"
        echo
        python3 bench/summarize.py "$LOG"
        echo "PoCL on the GPU machine's CPU, 128^3, scenario 2:"
        echo
        grep -v '^#' "$LOG/bench-pocl.txt" | sed 's/^/    /'
        echo
        for d in cuda opencl; do
            echo "petblur demo --device $d --size 128:"
            echo
            sed 's/^/    /' "$LOG/demo-$d.txt"
            echo
        done
        for d in cuda opencl; do
            echo "Twenty frames of 256^3 in one pb_blur_frames call against one pb_blur per frame ($d):"
            echo
            sed 's/^/    /' "$LOG/frames-$d.txt"
            echo
        done
    } | tee "$OUT/tables.md"
    tar -C "$(dirname "$LOG")" -czf "$OUT/logs.tar.gz" logs
    exit $status
)
