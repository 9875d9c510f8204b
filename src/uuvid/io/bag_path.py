"""Is a path a ROS bag?  A leaf the log readers share (no uuvid imports): the ArduSub readers
point a bag to the commands that read one, and :mod:`uuvid.io.dive_rosbag` reads it."""

from __future__ import annotations

from pathlib import Path

__all__ = ["is_bag", "bag_instead"]


def is_bag(path) -> bool:
    """A ROS 1 ``.bag`` file, a ROS 2 bag directory or a file inside one."""
    p = Path(path)
    return (p.suffix == ".bag" and p.is_file()) or (p.is_dir() and (p / "metadata.yaml").exists()) \
        or (p.is_file() and p.suffix in (".db3", ".mcap") and (p.parent / "metadata.yaml").exists())


def bag_instead(path) -> str | None:
    """The message for a ROS bag handed to `uuvid log` (which reads ArduSub logs: it said "unknown
    log type '.bag'", or "no such log file" of a ROS 2 bag folder), or ``None``."""
    p = Path(path)
    if not (p.exists() and is_bag(p)):
        return None
    return (f"{p}: a ROS bag; `uuvid log` reads ArduSub logs (.tlog, .bin, .log) — a bag of a dive "
            "is read by `uuvid vehicle identify dive` and `uuvid vehicle replay` (--vehicle, "
            "--topic)")
