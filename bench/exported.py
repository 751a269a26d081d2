"""Path (h) of the relay benches: the reuse relay of path (c), as ``nd.export`` writes it, built by the ROS's
own tool and run without ipyros.

* ROS 1: ``nd.export(DIR, language="cpp")``, then ``catkin_make``: a roscpp node whose relay is a
  ``topic_tools::ShapeShifter`` byte relay (beside topic_tools' relay (b) and ipyros's (c));
* ROS 2: ``nd.export(DIR)``, then ``colcon build``: the ament_python package's rclpy relay, its
  installed entry point (beside the hand-written rclpy relay (b) and ipyros's (c)).

The node is declared as (c)'s: a wrapping node around a basenode that publishes nothing, its
output relayed from the internal name. The bench runs the built node alone (not its launch file:
the bench's publisher stands for the basenode) with the internal name remapped onto the bench's
input topic, so it starts like (b): nothing to say, the bench publishes on its input.

    python -m bench.exported ros1|ros2 SRC KIND...   # declare and export one package a kind into SRC
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from bench.errors import BenchError

HERE = Path(__file__).resolve().parent
#: The message of each kind the benches send, by ROS type name (the same on both ROS).
TYPES = {"twist": "geometry_msgs/TwistStamped", "image": "sensor_msgs/Image"}


def package(kind: str) -> str:
    """The package of a kind, and its node's name (one catkin workspace builds each node under its own)."""
    return f"bench_h_{kind}"


def remap(ros: str, kind: str, topic_in: str, topic_out: str) -> list[str]:
    """What puts the exported node's relay on the bench's input: its internal name remapped."""
    from ipyros.core.model import NodeModel
    from ipyros.core.plan import internal_name

    internal = internal_name(NodeModel(package(kind)), topic_out)
    return [f"{internal}:={topic_in}"] if ros == "ros1" else ["--ros-args", "-r", f"{internal}:={topic_in}"]


def _run(argv: list[str], what: str, cwd: Path, env: dict[str, str], timeout: float) -> None:
    try:
        done = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    except (OSError, subprocess.TimeoutExpired) as error:
        raise BenchError(f"path (h): {what} failed: {error}") from None
    if done.returncode != 0:
        tail = " | ".join((done.stdout + done.stderr).strip().splitlines()[-6:])
        raise BenchError(f"path (h): {what} failed ({done.returncode}): {tail}")


def build(ros: str, workdir: Path, kinds: list[str], topic_out: str) -> Path:
    """Export (c)'s node once a kind into a workspace under ``workdir`` and build it; the folder whose
    ``<package>/<node>`` (ROS 1: ``devel/lib``) or ``<package>/lib/<package>/<node>`` (ROS 2: ``install``)
    is the built node. A one-line :class:`BenchError` if either step fails."""
    workspace = workdir / f"exported_{ros}"
    src = workspace / "src"
    src.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ)
    _run([sys.executable, "-m", "bench.exported", ros, str(src), topic_out, *kinds], "nd.export", HERE.parent, env,
         120)
    if ros == "ros1":
        _run(["catkin_make", "-C", str(workspace), f"-DPYTHON_EXECUTABLE={sys.executable}"], "catkin_make",
             workspace, env, 900)
        return workspace / "devel" / "lib"
    colcon = Path(sys.executable).with_name("colcon")
    _run([str(colcon), "build", "--base-paths", "src", "--build-base", "build", "--install-base", "install"],
         "colcon build", workspace, env, 300)
    return workspace / "install"


def command(ros: str, built: Path, kind: str) -> list[str]:
    """The built node of ``kind`` (or of ``"{kind}"``, for the bench to fill in), started as (b)'s relay is."""
    if ros == "ros1":
        return [str(built / package(kind) / package(kind))]
    return [sys.executable, str(built / package(kind) / "lib" / package(kind) / package(kind))]


def python_path(built: Path) -> list[str]:
    """Where an installed ROS 2 package's module is (colcon's install: lib/pythonX.Y/site-packages)."""
    return [str(p) for p in sorted(built.glob("*/lib/python3*/site-packages"))]


def _export(ros: str, src: Path, topic_out: str, kinds: list[str]) -> None:
    if ros == "ros2":
        os.environ["IPYROS_ROS"] = "2"
    from ipyros.dsl import rosNode

    for kind in kinds:
        node = rosNode(package(kind))
        node.baseNode("idle").basePackage("ipyros_bench")  # in the launch file only: the bench stands in for it
        node.reuse.publish(topic_out, type=TYPES[kind])
        if ros == "ros1":
            node.export(str(src / package(kind)), language="cpp")
        else:
            node.export(str(src / package(kind)))
        print("exported", package(kind), flush=True)


if __name__ == "__main__":
    _export(sys.argv[1], Path(sys.argv[2]), sys.argv[3], sys.argv[4:])
