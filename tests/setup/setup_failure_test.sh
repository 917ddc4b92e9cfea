#!/usr/bin/env bash
# A failed download in scripts/setup.sh must end with one clear line naming what failed and a
# non-zero exit. The package index is pointed at a closed port on loopback (nothing leaves the
# machine) and the dependency folder at an empty temporary one, so a download is attempted.
set -u
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
deps=$(mktemp -d)
trap 'rm -rf "$deps"' EXIT
err=$(env -u PIP_FIND_LINKS -u PIP_EXTRA_INDEX_URL RVWO_DEPS_DIR="$deps" PIP_CONFIG_FILE=/dev/null PIP_INDEX_URL=http://127.0.0.1:9/simple \
  RVWO_PIP_RETRIES=0 bash "$ROOT/scripts/setup.sh" 2>&1 >/dev/null)
rc=$?
lines=$(printf '%s\n' "$err" | grep -c .)
echo "exit $rc; stderr: $err"
if [ "$rc" -eq 0 ]; then echo "FAIL: setup succeeded without its package index"; exit 1; fi
if [ "$lines" -ne 1 ]; then echo "FAIL: expected one line on stderr, got $lines"; exit 1; fi
if ! printf '%s' "$err" | grep -Eq '^setup: FAILED: download of (onnxruntime|g2opy)==[0-9.]+ from PyPI \(details: .*setup.log\)$'; then
  echo "FAIL: the line does not name the failed download"; exit 1
fi
echo "ok"
