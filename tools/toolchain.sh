# Picks the Rust toolchain the crate builds with; sourced by the other scripts (bash).
#
# Bevy 0.20 needs Rust 1.97.1 (the crate's `rust-version`). In order of preference:
#  1. the default `cargo`, when it is 1.97.1 or newer;
#  2. another installed rustup toolchain that is 1.97.1 or newer (`cargo +NAME`);
#  3. an installed 1.97 nightly (1.97.0-nightly builds Bevy 0.20), with `--ignore-rust-version`,
#     said in one line on stderr;
#  otherwise it stops with what to install.
# Sets the array CARGO (the command) and CARGO_BUILD_FLAGS (flags for build, test, run, clippy,
# doc and bench). CARGO_TOOLCHAIN=NAME forces a rustup toolchain.

# Version triple of `cargo ARGS --version`, e.g. "1 97 1", or nothing.
_cartoon_hair_cargo_version() {
  "$@" --version 2>/dev/null | sed -n 's/^cargo \([0-9]*\)\.\([0-9]*\)\.\([0-9]*\).*/\1 \2 \3/p'
}

# Whether "MAJOR MINOR PATCH" is at least the given MAJOR MINOR PATCH.
_cartoon_hair_at_least() {
  local a b c
  read -r a b c <<<"$1"
  [ -n "$a" ] || return 1
  [ "$a" -gt "$2" ] && return 0
  [ "$a" -lt "$2" ] && return 1
  [ "$b" -gt "$3" ] && return 0
  [ "$b" -lt "$3" ] && return 1
  [ "$c" -ge "$4" ]
}

CARGO=()
CARGO_BUILD_FLAGS=()
if [ -n "${CARGO_TOOLCHAIN:-}" ]; then
  CARGO=(cargo "+$CARGO_TOOLCHAIN")
  if ! _cartoon_hair_at_least "$(_cartoon_hair_cargo_version "${CARGO[@]}")" 1 97 1; then
    CARGO_BUILD_FLAGS=(--ignore-rust-version)
  fi
elif _cartoon_hair_at_least "$(_cartoon_hair_cargo_version cargo)" 1 97 1; then
  CARGO=(cargo)
else
  _cartoon_hair_fallback=""
  if command -v rustup >/dev/null 2>&1; then
    for _cartoon_hair_tc in $(rustup toolchain list 2>/dev/null | awk '{print $1}'); do
      _cartoon_hair_v="$(_cartoon_hair_cargo_version cargo "+$_cartoon_hair_tc")"
      if _cartoon_hair_at_least "$_cartoon_hair_v" 1 97 1; then
        CARGO=(cargo "+$_cartoon_hair_tc")
        break
      fi
      if [ -z "$_cartoon_hair_fallback" ] && [[ "$_cartoon_hair_tc" == nightly* ]] &&
        _cartoon_hair_at_least "$_cartoon_hair_v" 1 97 0; then
        _cartoon_hair_fallback="$_cartoon_hair_tc"
      fi
    done
  fi
  if [ ${#CARGO[@]} -eq 0 ] && [ -n "$_cartoon_hair_fallback" ]; then
    CARGO=(cargo "+$_cartoon_hair_fallback")
    CARGO_BUILD_FLAGS=(--ignore-rust-version)
    echo "toolchain: cargo is older than Rust 1.97.1 (Bevy 0.20's minimum); using the installed $_cartoon_hair_fallback ($("${CARGO[@]}" --version)) with --ignore-rust-version" >&2
  fi
  if [ ${#CARGO[@]} -eq 0 ]; then
    echo "error: bevy_cartoon_hair needs Rust 1.97.1 or newer (Bevy 0.20), and found $(cargo --version 2>/dev/null || echo 'no cargo')." >&2
    echo "Install it with 'rustup update stable' (or 'rustup toolchain install 1.97.1'), then run this again." >&2
    exit 1
  fi
fi
