#!/usr/bin/env bash
# Checks that every feature set CI compiles alone gets its dependencies compiled with the same
# features as the test build (`cargo test --all-features`, which clippy's `--all-targets
# --all-features` check shares), so that CI compiles Bevy once, not once per set.
#
#   tools/feature-sets.sh
#
# Each of .ci/run's feature-set commands is planned with `cargo --unit-graph` (nothing is
# compiled; an unstable flag, allowed on a stable toolchain by RUSTC_BOOTSTRAP for these calls
# only) for the crate together with tools/shared-deps, the package that names the dependency
# features an optional or development dependency turns on. Prints each dependency whose features
# differ and what to add to tools/shared-deps/Cargo.toml; exits 1 if any differ.
set -euo pipefail
cd "$(dirname "$0")/.."
source tools/toolchain.sh
S=(-p bevy_cartoon_hair -p bevy_cartoon_hair_shared_deps)
# The commands of .ci/run, without their output flags.
SETS=(
  "check --lib --no-default-features"
  "check --lib --no-default-features --features render"
  "check --lib --no-default-features --features rapier"
  "check --lib --no-default-features --features ui"
  "check --lib --no-default-features --features demo"
  "check --examples --no-default-features --features render"
  "test --lib --no-default-features --features avian"
)
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
plan() {
  local cmd="$1"
  shift
  RUSTC_BOOTSTRAP=1 "${CARGO[@]}" "$cmd" "${CARGO_BUILD_FLAGS[@]}" --locked --unit-graph \
    -Z unstable-options "$@"
}
plan test --all-features >"$work/all"
for i in "${!SETS[@]}"; do
  # shellcheck disable=SC2086 # each set is several words
  plan ${SETS[$i]} "${S[@]}" >"$work/set$i"
done
python3 - "$work" "${SETS[@]}" <<'PY'
import json
import sys


def features(path):
    """{(package, target, build script run or not): {feature tuples}}, this crate's own two
    packages left out."""
    out = {}
    for unit in json.load(open(path))["units"]:
        package = unit["pkg_id"]
        if "bevy_cartoon_hair" in package.rsplit("#", 1)[-1]:
            continue
        key = (package, unit["target"]["name"], unit["mode"] == "run-custom-build")
        out.setdefault(key, set()).add(tuple(sorted(unit["features"])))
    return out


def name(package):
    return package.rsplit("#", 1)[-1]


work, sets = sys.argv[1], sys.argv[2:]
every = features(f"{work}/all")
# {(package, lacks, has extra): [commands]}
found = {}
for i, command in enumerate(sets):
    for key, have in sorted(features(f"{work}/set{i}").items()):
        want = every.get(key, set())
        for unit in have - want:
            # Against the test build's closest unit of the package (its host and target units
            # may differ).
            near = min(want, key=lambda w: len(set(w) ^ set(unit)), default=())
            lacks = tuple(sorted(set(near) - set(unit)))
            extra = tuple(sorted(set(unit) - set(near)))
            found.setdefault((name(key[0]), lacks, extra), []).append(f"cargo {command}")
for (package, lacks, extra), commands in sorted(found.items()):
    print(f"{package}: lacks the test build's features [{', '.join(lacks)}]"
          + (f", has [{', '.join(extra)}] it does not" if extra else "")
          + f", in {len(commands)} of {len(sets)} commands ({commands[0]}, ...): name it in "
          "tools/shared-deps/Cargo.toml with those features")
if found:
    sys.exit(1)
print(f"feature sets: {len(sets)} commands compile their dependencies as the test build does")
PY
