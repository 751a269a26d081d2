#!/usr/bin/env bash
# One entry point for a fresh Debian bookworm machine (as root):
#   bash run.sh           install what is missing, then start IPython with ipyros loaded and the
#                         demo turtle running (on the master at ROS_MASTER_URI, started if none answers)
#   bash run.sh ipython   the same without the demo robot
#   bash run.sh notebook  the notebooks in Jupyter (installs Jupyter into the venv the first time)
#   bash run.sh test      install what is missing, then run the whole test suite: the unit layer (no ROS),
#                         the guide built with warnings as errors, then tests/both + tests/ros1 on ROS 1 (the notebooks
#                         among them in JupyterLab in a headless Chromium), then tests/both + tests/ros2 on ROS 2
#                         (rclpy from PyPI, in a venv of its own); each is run and reported, whatever
#                         the one before it did
#   bash run.sh unit      the unit layer alone, in a venv without ROS (seconds)
#   bash run.sh docs      the guide (docs/), built by Sphinx with warnings as errors into docs/_build/html
#   bash run.sh test-ros1 the ROS 1 layers alone;  bash run.sh test-ros2  the ROS 2 layers alone
#   bash run.sh ros2      the same as bash run.sh, on ROS 2 (rclpy from PyPI, no ROS from apt), in
#                         the DDS domain of ROS_DOMAIN_ID (0 if unset)
#   bash run.sh bench     install what is missing, then run the benchmarks (ROS 1's, then ROS 2's) and print
#                         one table of every figure beside its anchor (bench/results/summary.md)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
venv="$here/.venv"

# ROS 1 from Debian, and the venv that sees it.
ros1_setup() {
  local apt_packages=(
    python3-venv python3-pip
    python3-rospy python3-rostopic python3-rosgraph python3-rosnode python3-rosmaster
    python3-roslaunch python3-rosservice python3-rosparam rosout rosbash topic-tools
    python3-std-msgs python3-geometry-msgs python3-sensor-msgs python3-std-srvs
    python3-rosgraph-msgs python3-rosbag python3-actionlib python3-actionlib-msgs python3-dynamic-reconfigure
    python3-genpy tmux
    # nd.export(DIR, language="cpp"): the roscpp node it writes is built with catkin_make
    catkin g++ cmake libroscpp-dev libtopic-tools-dev libstd-msgs-dev libgeometry-msgs-dev libstd-srvs-dev
    libsensor-msgs-dev  # the relay bench's path (h) relays images too
    chromium  # the notebooks checked in a real browser (tests/ros1/test_browser.py, playwright drives it)
    nftables iproute2  # a lossy link to a robot in its own network namespace (tests/both/test_machine_link.py)
    graphviz  # %graph lays the live graph out with dot (an SVG in Jupyter, --save FILE.svg|.png)
  )

  local missing=() p stamp
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
    "$venv/bin/pip" install -q --disable-pip-version-check -e "$here[test,bags,browser]" >&2
    touch "$stamp"
  fi
}

# ROS 2 from PyPI, in a venv of its own: it must not see the system's site-packages, where
# Debian's ROS 1 message packages (std_msgs, ...) would shadow the ROS 2 ones.
venv2="$here/.venv-ros2"
ros2_packages=("ros-rclpy[fastrtps]" ros-std-msgs ros-geometry-msgs ros-sensor-msgs ros-std-srvs ros-rcl-interfaces
               ros-action-msgs ros-test-msgs  # actions: test_msgs/action/Fibonacci serves the tests and the README
               rosbags  # rosbags: ROS 2 bags (%record, baseBag); rosbag2 is not on PyPI
               mcap  # the tests read back what %record wrote with MCAP's own reader too
               catkin_pkg  # build_messages: rosidl_adapter reads .msg files with it
               colcon-common-extensions)  # builds the ament_python package nd.export(DIR) writes
# Debian splits venv support out of Python: the venvs without ROS 1 need it before apt installs the rest.
venv_support() {
  if ! /usr/bin/python3 -c "import ensurepip" 2>/dev/null; then
    echo "run.sh: installing python3-venv" >&2
    DEBIAN_FRONTEND=noninteractive apt-get update -q >&2
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends python3-venv >&2
  fi
}
ros2_venv() {
  venv_support
  if [[ ! -x "$venv2/bin/python" ]]; then
    /usr/bin/python3 -m venv "$venv2"
  fi
  local stamp2="$venv2/.ipyros-installed"
  if [[ ! -f "$stamp2" || "$here/pyproject.toml" -nt "$stamp2" || "$here/run.sh" -nt "$stamp2" ]]; then
    echo "run.sh: installing ROS 2 (rclpy, from PyPI) into $venv2" >&2
    "$venv2/bin/pip" install -q --disable-pip-version-check "${ros2_packages[@]}" -e "$here[test]" >&2
    touch "$stamp2"
  fi
}

# The unit layer runs where no ROS is: a venv of its own, without the system's site-packages.
venv0="$here/.venv-unit"
unit_venv() {
  venv_support
  if [[ ! -x "$venv0/bin/python" ]]; then
    /usr/bin/python3 -m venv "$venv0"
  fi
  local stamp0="$venv0/.ipyros-installed"
  if [[ ! -f "$stamp0" || "$here/pyproject.toml" -nt "$stamp0" ]]; then
    "$venv0/bin/pip" install -q --disable-pip-version-check -e "$here[unit,docs]" >&2
    touch "$stamp0"
  fi
}

# The guide, with every Sphinx warning an error (a broken link, a magic's help that does not parse).
build_docs() {
  "$venv0/bin/python" -m sphinx -W --keep-going -q -b html "$here/docs" "$here/docs/_build/html"
}

# Runs one layer of the suite and notes how it ended, so that every layer runs and is reported.
results=()
layer() {
  local label="$1" rc=0 start=$SECONDS
  shift
  "$@" || rc=$?
  record "$label" "$rc" "$((SECONDS - start))"
}
record() {
  if (($2 == 0)); then results+=("$1: passed in $3 s"); else results+=("$1: FAILED (pytest exit $2) in $3 s"); fi
  return 0
}
report() {
  local line failed=0
  echo >&2
  for line in "${results[@]}"; do
    echo "run.sh test: $line" >&2
    [[ "$line" == *FAILED* ]] && failed=1
  done
  return "$failed"
}

# Jupyter, for the notebook target only (the tests run notebooks without it).
notebook() {
  if ! "$venv/bin/python" -c "import notebook" 2>/dev/null; then
    echo "run.sh: installing Jupyter into $venv" >&2
    "$venv/bin/pip" install -q --disable-pip-version-check -e "$here[jupyter]" >&2
  fi
  # One master for every kernel: each kernel would otherwise start its own, and take it
  # along when it shuts down. This one stops with the Jupyter server (if it started it).
  # Ctrl-C is Jupyter's to answer (it asks first): the helper ignores it, and ends on the
  # SIGTERM of the trap below; its master and rosout get the default SIGINT back, so that
  # they stop at once when asked.
  "$venv/bin/python" -c '
import signal, threading
from ipyros.ros1 import master
signal.signal(signal.SIGINT, signal.SIG_DFL)
handle = master.attach()
signal.signal(signal.SIGINT, signal.SIG_IGN)
print("run.sh: ipyros:", handle.describe(), flush=True)
stop = threading.Event()
signal.signal(signal.SIGTERM, lambda *_: stop.set())
stop.wait()
handle.stop()' &
  local master_pid=$!
  # Expanded now: master_pid is local, and gone when the trap runs at exit.
  trap "kill $master_pid 2>/dev/null; wait $master_pid 2>/dev/null" EXIT
  local root=()
  [[ $EUID -ne 0 ]] || root=(--allow-root)  # Jupyter refuses root unless told
  "$venv/bin/jupyter" notebook --notebook-dir="$here/notebooks" "${root[@]}" "$@"
}

cmd="${1:-demo}"
shift || true
[[ "$cmd" == ros2 || "$cmd" == test-ros2 || "$cmd" == unit || "$cmd" == docs || "$cmd" == test ]] || ros1_setup
case "$cmd" in
  ros2)     # discovery kept to this machine unless asked (ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET reaches a robot)
            ros2_venv && AMENT_PREFIX_PATH="${AMENT_PREFIX_PATH:-$venv2}" IPYROS_ROS=2 \
              ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}" \
              exec "$venv2/bin/ipython" --ext ipyros --InteractiveShellApp.exec_lines='["%demo"]' "$@" ;;
  demo)     exec "$venv/bin/ipython" --ext ipyros --InteractiveShellApp.exec_lines='["%demo"]' "$@" ;;
  ipython)  exec "$venv/bin/ipython" --ext ipyros "$@" ;;
  notebook) notebook "$@" ;;
  machine)  # the keeper of the robot's machine: bash run.sh machine robot1 --allow PKG (its ROS_MASTER_URI: the robot's master)
            [[ $# -ge 1 ]] || { echo "usage: bash run.sh machine NAME [--allow PACKAGE ...] [--token-file FILE]" >&2; exit 2; }
            exec "$venv/bin/python" -m ipyros.machine --name "$@" ;;
  test)     # every layer, each reported; with arguments, pytest gets them in the ROS 1 venv only
            cd "$here"
            if (($# > 0)); then ros1_setup && exec "$venv/bin/python" -m pytest "$@"; fi
            # The venvs without ROS 1 are made while apt and the ROS 1 venv install (minutes saved on a fresh
            # machine); apt runs alone, as the ROS 1 venv's pip must see what it installed.
            venv_support
            unit_venv & unit_pid=$!
            ros2_venv & ros2_pid=$!
            trap wait EXIT  # one install failing: the others end before the script does, none left running
            ros1_setup
            wait "$unit_pid"
            wait "$ros2_pid"
            trap - EXIT
            results+=("installs: done in $SECONDS s")
            layer "unit (no ROS)" "$venv0/bin/python" -m pytest -q tests/unit
            layer "guide (sphinx -W)" build_docs
            # One after the other: side by side on two cores the load made timing-bound tests fail.
            layer "ROS 1" "$venv/bin/python" -m pytest --durations=10 tests/both tests/ros1
            layer "ROS 2" "$venv2/bin/python" -m pytest --durations=10 tests/both tests/ros2
            report ;;
  unit)     cd "$here" && unit_venv && exec "$venv0/bin/python" -m pytest tests/unit "$@" ;;
  docs)     cd "$here" && unit_venv && build_docs && echo "the guide: $here/docs/_build/html/index.html" ;;
  test-ros1) cd "$here" && exec "$venv/bin/python" -m pytest tests/both tests/ros1 "$@" ;;
  test-ros2) cd "$here" && ros2_venv && exec "$venv2/bin/python" -m pytest tests/both tests/ros2 "$@" ;;
  bench)    # ROS 1's benchmarks, then ROS 2's in its venv, then one table of every figure beside its anchor
            cd "$here" && status=0
            rm -rf "$here/bench/results/figures"  # the table is this run's alone
            "$venv/bin/python" -m bench "$@" || status=$?
            ros2_venv && "$venv2/bin/python" -m bench "$@" || status=$?
            "$venv/bin/python" -m bench.figures || status=$?
            exit "$status" ;;
  *) echo "usage: bash run.sh [demo|ipython|ros2|notebook|machine|test|unit|docs|test-ros1|test-ros2|bench] [args...]" >&2
     exit 2 ;;
esac
