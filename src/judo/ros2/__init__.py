"""judo on a ROS 2 graph over DDS, with no ROS install (extra `ros2`: pip install -e ".[ros2]").

- `judo.ros2.bridge.Ros2System`: a robot as judo's `System` (`python -m judo --system ros2`);
- `judo.ros2.plant`: judo's simulator as a robot process (`python -m judo plant --task T`);
- `judo.ros2.messages`: ROS 2's standard messages as DDS types; `judo.ros2.mcap_log`: MCAP logs
  (`--record`).

Nothing below `judo.ros2` imports it; the app loads the bridge by name.
"""
