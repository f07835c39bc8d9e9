#!/usr/bin/env bash
# The README's two commands in either order: ./scripts/demo.sh configures its build dir with the
# tests off; a following ./scripts/test.sh must turn them on again (CMake keeps the cache). In a
# scratch build dir, configure the demo way, check it registers no test, then the test way, and
# check it registers every test of the build running this test (the CTest tests and the
# GoogleTest executables, whose tests are listed once built). Configure only: no build.
# Usage: readme_order_test.sh SOURCE_DIR BUILD_DIR_OF_THIS_TEST
set -euo pipefail
src=$1
this_build=$2
fail() { echo "FAIL: $*"; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# Registered tests, from the CTestTestfile.cmake files (no build needed): the add_test() entries
# plus one per GoogleTest executable (gtest_discover_tests includes a file per executable, which
# lists its tests once it is built).
count_tests() {
  find "$1" -name CTestTestfile.cmake -exec cat {} + 2>/dev/null |
    grep -c -E '^add_test\(|^include\(.*_include\.cmake"\)' || true
}
expected=$(count_tests "$this_build")
(( expected > 10 )) || fail "this build registers only $expected tests"

cd "$src"
BUILD_DIR=$work/build AEROVO_CONFIGURE_ONLY=1 ./scripts/demo.sh >"$work/demo.log" 2>&1 ||
  { cat "$work/demo.log"; fail "demo.sh's configure failed"; }
after_demo=$(count_tests "$work/build")
[[ $after_demo == 0 ]] || fail "demo.sh registered $after_demo tests (it builds with tests off)"

BUILD_DIR=$work/build AEROVO_CONFIGURE_ONLY=1 ./scripts/test.sh >"$work/test.log" 2>&1 ||
  { cat "$work/test.log"; fail "test.sh's configure failed"; }
after_test=$(count_tests "$work/build")
(( after_test >= expected )) ||
  fail "after demo.sh then test.sh: $after_test tests registered, this build has $expected"
# ctest of an empty build dir fails the way test.sh calls it.
mkdir "$work/empty"
if ctest --test-dir "$work/empty" --no-tests=error >/dev/null 2>&1; then
  fail "ctest --no-tests=error passed with no test"
fi
echo "PASS: demo.sh then test.sh registers $after_test tests (this build: $expected)"
