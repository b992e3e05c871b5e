#!/usr/bin/env bash
# Coverage-guided fuzzing (cargo fuzz, libFuzzer) of every loader and the solver step.
#
#   tools/fuzz.sh [SECONDS_PER_TARGET] [TARGET ...]
#
# Builds the targets in fuzz/ on the nightly toolchain (cargo-fuzz is installed if missing), then
# runs each for SECONDS_PER_TARGET (default 60), going on past crashes (libFuzzer's fork mode), and
# prints, per target, executions, coverage
# (libFuzzer's `cov`, edges, and `ft`, features) and crashes. Seeds come from fuzz/seeds/<target>;
# what libFuzzer finds is kept in $FUZZ_WORK (default ~/.cache/bevy_cartoon_hair/fuzz), outside
# the clone. A crash's input is written there under artifacts/<target>/ and named in the summary;
# the script then exits non-zero. Not a CI step: the crashes it found are regression tests in the
# normal suite.
set -euo pipefail

cd "$(dirname "$0")/.."
seconds="${1:-60}"
shift || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  targets=(groom collision animation preset solver_step vrm)
fi
work="${FUZZ_WORK:-$HOME/.cache/bevy_cartoon_hair/fuzz}"
target_dir="${FUZZ_TARGET_DIR:-$HOME/.cache/bevy_cartoon_hair/fuzz-target}"

toolchain=""
for tc in $(rustup toolchain list 2>/dev/null | awk '{print $1}'); do
  case "$tc" in nightly*) toolchain="$tc"; break ;; esac
done
if [ -z "$toolchain" ]; then
  echo "error: cargo fuzz needs a nightly toolchain; install one with 'rustup toolchain install nightly'" >&2
  exit 1
fi
if ! cargo "+$toolchain" fuzz --version >/dev/null 2>&1; then
  echo "installing cargo-fuzz (cargo install cargo-fuzz --locked)" >&2
  cargo install cargo-fuzz --locked
fi

# Bevy 0.20 declares Rust 1.97.1; a 1.97 nightly builds it but cargo refuses it unless told to
# ignore that. cargo-fuzz cannot pass the flag, so a wrapper named `cargo` first on PATH adds it.
source tools/toolchain.sh
if ! _cartoon_hair_at_least "$(_cartoon_hair_cargo_version cargo "+$toolchain")" 1 97 1; then
  wrapper="$(mktemp -d)"
  trap 'rm -rf "$wrapper"' EXIT
  real_cargo="$(command -v cargo)"
  cat >"$wrapper/cargo" <<WRAP
#!/bin/sh
case "\$1" in
  build|rustc) sub="\$1"; shift; exec "$real_cargo" "\$sub" --ignore-rust-version "\$@" ;;
esac
exec "$real_cargo" "\$@"
WRAP
  chmod +x "$wrapper/cargo"
  PATH="$wrapper:$PATH"
fi

# Rust is memory-safe here (no unsafe in the crate): no address sanitizer, coverage only.
# Bevy is large: 16 codegen units instead of cargo-fuzz's 1 keep the build within minutes.
build=(cargo "+$toolchain" fuzz build --sanitizer none --codegen-units 16 --target-dir "$target_dir")
echo "building ${targets[*]} with $toolchain" >&2
"${build[@]}" "${targets[@]:0:1}" >&2
for t in "${targets[@]:1}"; do "${build[@]}" "$t" >&2; done

triple="$(rustc "+$toolchain" -vV | sed -n 's/^host: //p')"
status=0
printf '%-12s %12s %8s %8s %8s  %s\n' target executions cov ft crashes "corpus (seeds + found)"
for t in "${targets[@]}"; do
  corpus="$work/corpus/$t"
  artifacts="$work/artifacts/$t"
  mkdir -p "$corpus" "$artifacts"
  log="$work/$t.log"
  set +e
  "$target_dir/$triple/release/$t" "$corpus" "fuzz/seeds/$t" \
    -max_total_time="$seconds" -print_final_stats=1 -rss_limit_mb=4096 -timeout=10 \
    -fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1 \
    -artifact_prefix="$artifacts/" >"$log" 2>&1
  rc=$?
  set -e
  # Fork mode's last status line starts with the executions so far: "#12345: cov: ...".
  execs=$( (grep -o '^#[0-9]*' "$log" || true) | tail -1 | tr -d '#')
  cov=$( (grep -o 'cov: [0-9]*' "$log" || true) | tail -1 | awk '{print $2}')
  ft=$( (grep -o 'ft: [0-9]*' "$log" || true) | tail -1 | awk '{print $2}')
  crashes=$(find "$artifacts" -type f | wc -l)
  files=$(find "$corpus" -type f | wc -l)
  seeds=$(find "fuzz/seeds/$t" -type f 2>/dev/null | wc -l)
  printf '%-12s %12s %8s %8s %8s  %s\n' "$t" "${execs:-?}" "${cov:-?}" "${ft:-?}" "$crashes" "$seeds + $files"
  if [ "$rc" -ne 0 ] || [ "$crashes" -ne 0 ]; then
    status=1
    echo "  $t: libFuzzer exited $rc; log $log" >&2
    find "$artifacts" -type f -printf '  crash input: %p\n' >&2
  fi
done
exit "$status"
