# Functions of scripts/setup.sh (sourced): wait for the package manager's lock, one set-up of a clone at a time.
# FCGEN_APT_WAIT: seconds to wait for another apt-get/dpkg to finish (default 600); FCGEN_SETUP_WAIT: seconds to wait
# for another scripts/setup.sh of the same clone (default 1800).

apt_run() {  # apt-get "$@" (sudo when not root), waiting up to FCGEN_APT_WAIT s while another install holds the lock
  local sudo="" wait="${FCGEN_APT_WAIT:-600}" log rc start=$SECONDS said=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  log="$(mktemp)"
  while :; do
    rc=0
    # DPkg::Lock::Timeout: apt itself waits for the dpkg frontend lock; the loop covers the lists lock of `update`
    DEBIAN_FRONTEND=noninteractive $sudo apt-get -o "DPkg::Lock::Timeout=$wait" "$@" 2>"$log" || rc=$?
    if [ "$rc" -eq 0 ] || ! grep -q "Could not get lock\|Unable to acquire the dpkg" "$log"; then
      cat "$log" >&2; rm -f "$log"; return "$rc"
    fi
    if [ $((SECONDS - start)) -ge "$wait" ]; then
      cat "$log" >&2; rm -f "$log"
      echo "setup: the package manager is still busy after ${wait} s (another apt-get or dpkg holds its lock," \
        "see above); let it finish, then run 'bash scripts/setup.sh' again (FCGEN_APT_WAIT=SECONDS waits longer)" >&2
      return 100
    fi
    [ -n "$said" ] || echo "setup: another apt-get or dpkg is running; waiting for it (at most ${wait} s)" >&2
    said=1
    sleep "${FCGEN_APT_RETRY:-5}"
  done
}

apt_install() {  # apt-get update + install "$@", each waiting for the package manager's lock
  echo "setup: installing $* with apt-get" >&2
  apt_run update -qq && apt_run install -y -qq "$@"
}

setup_lock() {  # hold an exclusive lock of this clone (fd 9, on its folder) until the script exits
  command -v flock >/dev/null 2>&1 || return 0
  exec 9<"$PWD"
  flock -n 9 && return 0
  local wait="${FCGEN_SETUP_WAIT:-1800}"
  echo "setup: another scripts/setup.sh of $PWD is running; waiting for it (at most ${wait} s)" >&2
  flock -w "$wait" 9 && return 0
  echo "setup: the other scripts/setup.sh of $PWD still runs after ${wait} s; let it finish, then run" \
    "'bash scripts/setup.sh' again (FCGEN_SETUP_WAIT=SECONDS waits longer)" >&2
  return 1
}
