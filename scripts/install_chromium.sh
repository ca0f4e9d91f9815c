#!/usr/bin/env bash
# Installs Chromium from Debian's packages when no Chromium is on the PATH
# (for scripts/check_report_browser.py). Needs root or sudo, as on the
# project's machines and CI.
set -euo pipefail
if command -v chromium > /dev/null || command -v chromium-browser > /dev/null \
  || command -v google-chrome > /dev/null; then
  exit 0
fi
sudo=""
if [ "$(id -u)" != 0 ]; then
  sudo=sudo
fi
echo "installing Chromium (Debian package chromium) for the report's browser check"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq chromium > /dev/null
