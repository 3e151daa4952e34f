#!/usr/bin/env bash
# Runs every fuzz target for SECONDS each (default 60) and prints executions per target.
#
#   fuzz/run.sh [SECONDS] [TARGET...]
#
# Needs the nightly toolchain and cargo-fuzz (`cargo install cargo-fuzz --locked`).
# Seeds come from fuzz/corpus/<target>/ (kept in the repository, small); inputs found
# during the run go to fuzz/corpus-work/<target>/ (ignored by git), crashes to
# fuzz/artifacts/<target>/. Exit status 1 if any target found a crash.
set -euo pipefail
cd "$(dirname "$0")"
secs="${1:-60}"
shift || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    targets=(frame_decoder controller sweep_csv plan_toml)
fi
cargo +nightly fuzz build -O >/dev/null 2>&1
status=0
for t in "${targets[@]}"; do
    mkdir -p "corpus-work/$t"
    log="corpus-work/$t.log"
    if cargo +nightly fuzz run -O "$t" "corpus-work/$t" "corpus/$t" -- \
        -max_total_time="$secs" -print_final_stats=1 >"$log" 2>&1; then
        result=ok
    else
        result="CRASH (see $log and artifacts/$t/)"
        status=1
    fi
    execs=$(grep -m1 'stat::number_of_executed_units' "$log" | awk '{print $2}')
    cov=$(grep -E '^#[0-9]+' "$log" | tail -1 | grep -oE 'cov: [0-9]+' || true)
    printf '%-14s %4ss  %12s executions  %-10s %s\n' "$t" "$secs" "${execs:-?}" "${cov:-}" "$result"
done
exit $status
