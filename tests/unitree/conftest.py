"""The Unitree tests import their helpers (unitree_links, leg_task) and the ROS 2 tests'
(ros2_links) by name."""

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
for folder in (HERE, HERE.parent / "ros2"):
    if str(folder) not in sys.path:
        sys.path.insert(0, str(folder))
