#: curvecost [curve_cost.py options]  issue 47: what the estimated track's curve costs FramesOperator against the line, on family draws (series grid and a clinical grid)
# Through the package installed beside the machine's torch (-Dopencl=disabled):
# bench/curve_cost.py on cuda:0, options going to it. Back through $OUT:
# machine.txt, curve.md (its output), curve.json.
#   PB_COMMIT=... bash bench/gpu.sh curvecost --draws 8
# (carry .device .whl)
# shellcheck shell=bash
mode_curvecost() (
    write_machine "$OUT/machine.txt" </dev/null
    install_package -Dopencl=disabled || exit 1
    (cd /tmp && python3 "$OLDPWD/bench/curve_cost.py" --out "$OUT/curve.json" "$@") 2>&1 | tee "$OUT/curve.md"
    exit "${PIPESTATUS[0]}"
)
