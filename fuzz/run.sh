#!/bin/sh
# fuzz/run.sh MODE SECONDS: runs every fuzz target for SECONDS.
#   MODE=long  (make fuzz): fork mode, crashes kept going, new inputs in
#              build/fuzz-corpus/<target>, crashes in build/fuzz-findings/.
#   MODE=smoke (make test-fuzz): a fixed seed, the first finding fails.
# The libFuzzer targets are in build/fuzz/fuzz (make fuzz-build); the Python
# one is fuzz/scene_fuzz.py (atheris) with PYTHON (default .venv/bin/python).
set -u
MODE=$1
SECONDS_EACH=$2
PYTHON=${PYTHON:-.venv/bin/python}
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export ASAN_OPTIONS=detect_leaks=1
status=0
run() {  # run NAME COMMAND...: the output goes to a log, its tail and stats to stdout
    name=$1; shift
    log=build/fuzz-logs/$name.log
    echo "fuzzing $name for $SECONDS_EACH s ($MODE)"
    "$@" >"$log" 2>&1
    rc=$?
    grep -E "^stat::number_of_executed_units|^#[0-9]+.*DONE|contract violated|^SUMMARY|^=+ Uncaught|^ *(AssertionError|[A-Za-z]+Error)" "$log" | tail -5
    if [ $rc -ne 0 ]; then
        echo "FAIL: $name exited with $rc (full log: $log)"
        status=1
    fi
}
mkdir -p build/fuzz-logs build/fuzz-findings
for target in find_roots render; do
    seeds=fuzz/corpus/$target
    if [ "$MODE" = long ]; then
        mkdir -p build/fuzz-corpus/$target
        run $target build/fuzz/fuzz/${target}_fuzz -fork=1 -ignore_crashes=1 -max_total_time="$SECONDS_EACH" \
            -timeout=20 -rss_limit_mb=2048 -artifact_prefix=build/fuzz-findings/$target- \
            build/fuzz-corpus/$target "$seeds"
    else
        rm -rf build/fuzz-smoke/$target && mkdir -p build/fuzz-smoke/$target
        run $target build/fuzz/fuzz/${target}_fuzz -seed=1 -max_total_time="$SECONDS_EACH" -timeout=20 \
            -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix=build/fuzz-smoke/$target- \
            build/fuzz-smoke/$target "$seeds"
    fi
done
# Atheris: one process (no fork mode); a finding stops it.
if [ "$MODE" = long ]; then
    mkdir -p build/fuzz-corpus/scene
    run scene "$PYTHON" fuzz/scene_fuzz.py -max_total_time="$SECONDS_EACH" -timeout=20 -rss_limit_mb=4096 \
        -artifact_prefix=build/fuzz-findings/scene- build/fuzz-corpus/scene fuzz/corpus/scene
else
    rm -rf build/fuzz-smoke/scene && mkdir -p build/fuzz-smoke/scene
    run scene "$PYTHON" fuzz/scene_fuzz.py -seed=1 -max_total_time="$SECONDS_EACH" -timeout=20 -rss_limit_mb=4096 \
        -print_final_stats=1 -artifact_prefix=build/fuzz-smoke/scene- build/fuzz-smoke/scene fuzz/corpus/scene
fi
exit $status
