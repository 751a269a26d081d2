#!/usr/bin/env bash
# One entry point for a fresh Debian bookworm machine (as root):
#   bash run.sh          install what is missing, then start IPython with ipyros loaded
#   bash run.sh test     install what is missing, then run the whole test suite
#   bash run.sh bench    install what is missing, then run the benchmarks
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
venv="$here/.venv"

apt_packages=(
  python3-venv python3-pip
  python3-rospy python3-rostopic python3-rosgraph python3-rosnode python3-rosmaster
  python3-roslaunch python3-rosservice python3-rosparam rosout rosbash topic-tools
  python3-std-msgs python3-geometry-msgs python3-sensor-msgs python3-std-srvs
  python3-rosgraph-msgs tmux
)

missing=()
for p in "${apt_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "run.sh: installing Debian packages: ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q >&2
  apt-get install -y -q --no-install-recommends "${missing[@]}" >&2
fi

# rospy lives in Debian's dist-packages: the venv must come from /usr/bin/python3.
if [[ ! -x "$venv/bin/python" ]]; then
  /usr/bin/python3 -m venv --system-site-packages "$venv"
fi
stamp="$venv/.ipyros-installed"
if [[ ! -f "$stamp" || "$here/pyproject.toml" -nt "$stamp" ]]; then
  "$venv/bin/pip" install -q --disable-pip-version-check -e "$here[test]" >&2
  touch "$stamp"
fi

cmd="${1:-ipython}"
shift || true
case "$cmd" in
  ipython) exec "$venv/bin/ipython" --ext ipyros "$@" ;;
  test)    cd "$here" && exec "$venv/bin/python" -m pytest "$@" ;;
  bench)   cd "$here" && exec "$venv/bin/python" -m bench "$@" ;;
  *) echo "usage: bash run.sh [ipython|test|bench] [args...]" >&2; exit 2 ;;
esac
