#!/bin/sh
# Make sure the Debian packages netdae needs are present: ngspice (batch
# simulator), libngspice0 (shared library) and libngspice0-dev (the
# unversioned libngspice.so that PySpice loads). Installs them with apt-get
# when they are missing and we are root; otherwise prints exactly what to
# install and carries on (tests that need ngspice then skip with a reason).
set -u
missing=""
command -v ngspice >/dev/null 2>&1 || missing="$missing ngspice"
found_lib=""
for d in /usr/lib/x86_64-linux-gnu /usr/lib/aarch64-linux-gnu /usr/lib /usr/local/lib /usr/lib64; do
    [ -e "$d/libngspice.so.0" ] && found_lib="$found_lib 0"
    [ -e "$d/libngspice.so" ] && found_lib="$found_lib dev"
done
case "$found_lib" in *0*) ;; *) missing="$missing libngspice0" ;; esac
case "$found_lib" in *dev*) ;; *) missing="$missing libngspice0-dev" ;; esac
[ -z "$missing" ] && exit 0
if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
    echo "netdae: installing Debian packages:$missing"
    export DEBIAN_FRONTEND=noninteractive
    apt-get install -y -q $missing >/dev/null 2>&1 || {
        apt-get update -q >/dev/null 2>&1
        apt-get install -y -q $missing >/dev/null || {
            echo "netdae: apt-get could not install:$missing" >&2
            exit 0
        }
    }
else
    echo "netdae: ngspice is missing. Install it with:"
    echo "    sudo apt-get install$missing"
    echo "(netdae itself works without it; the comparison with ngspice and its tests are skipped.)"
fi
exit 0
