#!/usr/bin/env bash
# The Debian packages some tests need beyond Python: installs the missing ones.
#
# Fast and silent when everything is there (one `dpkg -s` per package, no network);
# `apt-get update` runs only when something has to be installed. Without root or without
# apt-get it installs nothing: it says what is missing and exits 0, and the tests that need
# a missing package skip, naming it.
#
#   iproute2  `ip` and `tc`: the network-namespace test (tests/daemon/test_netns.py)
#   nftables  `nft`: that test's packet loss on kernels without sch_netem
#   chromium  the headless browser of the web ground station's end-to-end tests (tests/web)
#   fonts-dejavu-core  the font the page is drawn in (chromium's recommended fonts are
#             left out by --no-install-recommends)
set -euo pipefail

packages=(iproute2 nftables chromium fonts-dejavu-core)

if ! command -v dpkg >/dev/null 2>&1; then
    echo "system-deps: not a Debian system (no dpkg): install ${packages[*]} (or their" \
        "equivalents) yourself; until then the tests that need them are skipped" >&2
    exit 0
fi

missing=()
for package in "${packages[@]}"; do
    # `dpkg -s` succeeds for a package removed but not purged too: read its status line.
    if ! dpkg -s "$package" 2>/dev/null | grep -q '^Status: install ok installed'; then
        missing+=("$package")
    fi
done
[ ${#missing[@]} -eq 0 ] && exit 0

if [ "$(id -u)" -ne 0 ] || ! command -v apt-get >/dev/null 2>&1; then
    echo "system-deps: missing Debian packages: ${missing[*]}" >&2
    echo "system-deps: install them as root (apt-get install ${missing[*]});" \
        "until then the tests that need them are skipped" >&2
    exit 0
fi

echo "system-deps: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
