"""judo driving a Unitree robot over Unitree's own DDS messages, with no Unitree SDK (extra
`unitree`:
pip install -e ".[unitree]").

- `judo.unitree.bridge.UnitreeSystem`: a Go2 or G1 under low-level control as judo's `System`
  (`python -m judo --system unitree`): rt/lowstate in, rt/lowcmd out;
- `judo.unitree.robot`: judo's simulator as such a robot (`python -m judo plant --protocol
  unitree`);
- `judo.unitree.messages`: Unitree's IDL types on cyclonedds; `judo.unitree.crc`: the CRC a robot
  checks;
- `judo.unitree.motors`: a task's model as the robot's motors and its lowstate's sensors.

Nothing below `judo.unitree` imports it; the app loads the bridge by name.
"""
