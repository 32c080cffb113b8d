# Helpers for the CLI tests: a scratch directory and assertions that name what failed.
set -u
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
# expect_exit CODE CMD...: runs CMD, captures output in $out, checks the exit code.
expect_exit() {
  local want=$1; shift
  out=$("$@" 2>&1); local got=$?
  [ "$got" -eq "$want" ] || fail "'$*' exited $got, expected $want. Output: $out"
}
expect_output() { grep -q -- "$1" <<<"$out" || fail "output lacks '$1'. Output: $out"; }
finish() { [ "$failures" -eq 0 ] && echo "all checks passed" && exit 0; exit 1; }
