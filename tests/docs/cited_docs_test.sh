#!/usr/bin/env bash
# Every docs/... file that the code, the build and the scripts cite exists, every
# "docs/maths.md section N" they cite is a heading "## N." of that file, and every
# "docs/decisions/NNNN" a file docs/decisions/<NNNN>-<title>.md. Run from the source root.
set -euo pipefail
cd "${1:-.}"
status=0
sources=$(git ls-files '*.md' '*.h' '*.cc' '*.cmake' '*.in' '*.sh' '*.py' '*.yaml' 'CMakeLists.txt' '*/CMakeLists.txt')
# shellcheck disable=SC2086
while IFS=: read -r file line path; do
  if [ ! -f "$path" ]; then
    echo "$file:$line: cites $path, which does not exist"
    status=1
  fi
done < <(grep -noE 'docs/[A-Za-z0-9_./-]*[A-Za-z0-9_]\.md' $sources || true)
# shellcheck disable=SC2086
while IFS=: read -r file line n; do
  if ! grep -q "^## ${n}\. " docs/maths.md; then
    echo "$file:$line: cites docs/maths.md section $n, which has no heading '## $n.'"
    status=1
  fi
done < <(grep -noE 'docs/maths\.md,? section [0-9]+' $sources | sed -E 's/docs\/maths\.md,? section //' || true)
# shellcheck disable=SC2086
while IFS=: read -r file line n; do
  if ! compgen -G "docs/decisions/${n}-*.md" >/dev/null; then
    echo "$file:$line: cites docs/decisions/$n, which has no file docs/decisions/$n-*.md"
    status=1
  fi
done < <(grep -noE 'docs/decisions/[0-9]{4}' $sources | sed -E 's/:docs\/decisions\//:/' || true)
# shellcheck disable=SC2086
if grep -nq 'docs/maths\.md, "Slips"' $sources && ! grep -q '^## Slips$' docs/maths.md; then
  echo "docs/maths.md has no '## Slips' section, which kernels/include/rvwo/kernels/barron.h cites"
  status=1
fi
[ "$status" = 0 ] && echo "cited docs: all present"
exit "$status"
