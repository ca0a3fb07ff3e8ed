#!/usr/bin/env bash
# Installs a Debian package the tests need when its program is missing.
# Usage: ensure-debian-package.sh PROGRAM PACKAGE...
#   e.g. ensure-debian-package.sh /usr/bin/chromium chromium fonts-dejavu-core
set -euo pipefail
if [ "$#" -lt 2 ]; then
    echo "usage: $0 PROGRAM PACKAGE..." >&2
    exit 2
fi
program=$1
shift
if [ -x "$program" ]; then
    exit 0
fi
echo "$program is missing: installing Debian's $* for the tests"
if [ "$(id -u)" -eq 0 ]; then
    sudo=""
elif command -v sudo >/dev/null 2>&1; then
    sudo="sudo -n"
else
    echo "error: $program is missing and this user cannot install packages;" >&2
    echo "       install Debian's $*, then run 'make test' again" >&2
    exit 1
fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "$@" >/dev/null
test -x "$program"
