#: accuracy [sweep|sweep-cost] [accuracy_case.py options]  issue 31's accuracy case (AB, RM against scipy) and what the path bounds cost
# The package installed by pip beside the machine's torch (-Dopencl=disabled).
#  - no word: bench/accuracy_case.py on CUDA, AB and RM against the dense scipy
#    reference for path bounds from the default to 0.01 voxels and the paper's
#    one segment per tracked interval, with each blur's time (options go to
#    it); then bench/bound_cost.py: what the bounds cost in kernel time on
#    256^3 for the paper's eight scenarios and a tracked seizure. Back through
#    $OUT: accuracy.txt, accuracy.json, bound_cost.md, bound_cost.json.
#  - sweep: the same with AB sweep beside AB and RM (issue 31, item 3), its
#    bounds 0.1, 0.05 and 0.01 for the cost. Back: accuracy.txt, accuracy.json,
#    cost.md, cost.json; sweep-cost: the cost alone.
# machine.txt too. (carry .device .whl)
# shellcheck shell=bash disable=SC2054 # the options' values hold commas
mode_accuracy() (
    write_machine "$OUT/machine.txt" </dev/null
    install_package -Dopencl=disabled || exit 1
    what=${1:-}
    case $what in
    sweep | sweep-cost)
        shift
        accuracy=(--bounds default,0.25,0.1,0.05,0.01 --methods ab,ab-sweep,rm)
        cost=(--bounds 0.1,0.05,0.01 --methods ab,ab-sweep,rm)
        cost_out=cost
        ;;
    *)
        accuracy=(--bounds default,0.25,0.1,0.05,0.02,0.01,paper --methods ab,rm)
        cost=()
        cost_out=bound_cost
        ;;
    esac
    status=0
    if [ "$what" != sweep-cost ]; then
        (cd /tmp && python3 "$OLDPWD/bench/accuracy_case.py" --device cuda --times 3000 "${accuracy[@]}" \
            --out "$OUT/accuracy.json" "$@") 2>&1 | tee "$OUT/accuracy.txt"
        status=${PIPESTATUS[0]}
    fi
    (cd /tmp && python3 "$OLDPWD/bench/bound_cost.py" ${cost[@]+"${cost[@]}"} --out "$OUT/$cost_out.json") 2>&1 |
        tee "$OUT/$cost_out.md"
    [ "${PIPESTATUS[0]}" = 0 ] || status=1
    exit "$status"
)
