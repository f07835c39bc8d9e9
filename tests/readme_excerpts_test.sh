#!/usr/bin/env bash
# The README's C++ excerpts are the examples' text: every line of a ```cpp block of README.md
# (leading spaces aside; "// ..." lines mark an elision) is a line of a file in examples/.
# Usage: readme_excerpts_test.sh SOURCE_DIR
set -euo pipefail
src=$1
fail() { echo "FAIL: $*"; exit 1; }
strip() { sed -e 's/^[[:space:]]*//' -e 's/[[:space:]]*$//'; }
examples=$(cat "$src"/examples/*.cc | strip)
blocks=$(awk '/^```cpp$/ { on = 1; n++; next } /^```$/ { on = 0 } on' "$src/README.md" | strip)
[[ -n $blocks ]] || fail "README.md has no C++ excerpt"
n=0
while IFS= read -r line; do
  [[ -z $line || $line == "// ..."* ]] && continue
  grep -qxF -- "$line" <<<"$examples" || fail "README line not in examples/*.cc: $line"
  n=$((n + 1))
done <<<"$blocks"
echo "PASS: $n README lines found in examples/"
