# pyright: reportCallIssue=false, reportGeneralTypeIssues=false, reportAssignmentType=false, reportInvalidTypeForm=false
# pyright: reportArgumentType=false
# (cyclonedds' IDL dataclasses take `typename=` in the class line and sizes in `array[float32, 4]`,
# which its type hints do not describe)
"""Unitree's low-level DDS messages, written on `cyclonedds` (Unitree's IDL, as unitree_sdk2
publishes it).

The Go2 speaks `unitree_go::msg::dds_::*`, the G1 `unitree_hg::msg::dds_::*`, on the DDS topics
`rt/lowstate` (the robot's readings) and `rt/lowcmd` (the commands it runs its per-motor PD on).
Each class keeps Unitree's field order, types and array sizes exactly: the CDR on the wire and the
bytes the CRC covers (`judo.unitree.crc`) follow them. Every message is `@final` with sequential
member ids, as Unitree's are.
"""

from dataclasses import dataclass, field

from judo.core.errors import import_extra

import_extra("cyclonedds", "the Unitree bridge", "unitree")

import cyclonedds.idl.annotations as annotate  # noqa: E402
from cyclonedds.idl import IdlStruct  # noqa: E402
from cyclonedds.idl.types import array, float32, int16, int32, uint8, uint16, uint32  # noqa: E402

GO_MOTORS = 20
"""Motor slots in a Go2 message (12 used: FR, FL, RR, RL legs, each hip, thigh, calf)."""
HG_MOTORS = 35
"""Motor slots in a G1 message (29 used on the 29-DoF G1)."""


def _zeros(n: int, value: float | int = 0) -> object:
    return field(default_factory=lambda: [value] * n)


def _bytes(n: int) -> object:
    """A uint8 array's default: bytes, as cyclonedds decodes one."""
    return field(default_factory=lambda: bytes(n))


# unitree_go: the Go2


@dataclass
@annotate.final
@annotate.autoid("sequential")
class GoMotorCmd(IdlStruct, typename="unitree_go::msg::dds_::MotorCmd_"):
    mode: uint8 = 0
    q: float32 = 0.0
    dq: float32 = 0.0
    tau: float32 = 0.0
    kp: float32 = 0.0
    kd: float32 = 0.0
    reserve: array[uint32, 3] = _zeros(3)


@dataclass
@annotate.final
@annotate.autoid("sequential")
class GoMotorState(IdlStruct, typename="unitree_go::msg::dds_::MotorState_"):
    mode: uint8 = 0
    q: float32 = 0.0
    dq: float32 = 0.0
    ddq: float32 = 0.0
    tau_est: float32 = 0.0
    q_raw: float32 = 0.0
    dq_raw: float32 = 0.0
    ddq_raw: float32 = 0.0
    temperature: uint8 = 0
    lost: uint32 = 0
    reserve: array[uint32, 2] = _zeros(2)


@dataclass
@annotate.final
@annotate.autoid("sequential")
class GoIMUState(IdlStruct, typename="unitree_go::msg::dds_::IMUState_"):
    quaternion: array[float32, 4] = field(default_factory=lambda: [1.0, 0.0, 0.0, 0.0])
    """[w, x, y, z]."""
    gyroscope: array[float32, 3] = _zeros(3, 0.0)
    accelerometer: array[float32, 3] = _zeros(3, 0.0)
    rpy: array[float32, 3] = _zeros(3, 0.0)
    temperature: uint8 = 0


@dataclass
@annotate.final
@annotate.autoid("sequential")
class GoBmsCmd(IdlStruct, typename="unitree_go::msg::dds_::BmsCmd_"):
    off: uint8 = 0
    reserve: array[uint8, 3] = _bytes(3)


@dataclass
@annotate.final
@annotate.autoid("sequential")
class GoBmsState(IdlStruct, typename="unitree_go::msg::dds_::BmsState_"):
    version_high: uint8 = 0
    version_low: uint8 = 0
    status: uint8 = 0
    soc: uint8 = 0
    current: int32 = 0
    cycle: uint16 = 0
    bq_ntc: array[uint8, 2] = _bytes(2)
    mcu_ntc: array[uint8, 2] = _bytes(2)
    cell_vol: array[uint16, 15] = _zeros(15)


@dataclass
@annotate.final
@annotate.autoid("sequential")
class GoLowCmd(IdlStruct, typename="unitree_go::msg::dds_::LowCmd_"):
    head: array[uint8, 2] = _bytes(2)
    level_flag: uint8 = 0
    frame_reserve: uint8 = 0
    sn: array[uint32, 2] = _zeros(2)
    version: array[uint32, 2] = _zeros(2)
    bandwidth: uint16 = 0
    motor_cmd: array[GoMotorCmd, GO_MOTORS] = field(
        default_factory=lambda: [GoMotorCmd() for _ in range(GO_MOTORS)]
    )
    bms_cmd: GoBmsCmd = field(default_factory=GoBmsCmd)
    wireless_remote: array[uint8, 40] = _bytes(40)
    led: array[uint8, 12] = _bytes(12)
    fan: array[uint8, 2] = _bytes(2)
    gpio: uint8 = 0
    reserve: uint32 = 0
    crc: uint32 = 0


@dataclass
@annotate.final
@annotate.autoid("sequential")
class GoLowState(IdlStruct, typename="unitree_go::msg::dds_::LowState_"):
    head: array[uint8, 2] = _bytes(2)
    level_flag: uint8 = 0
    frame_reserve: uint8 = 0
    sn: array[uint32, 2] = _zeros(2)
    version: array[uint32, 2] = _zeros(2)
    bandwidth: uint16 = 0
    imu_state: GoIMUState = field(default_factory=GoIMUState)
    motor_state: array[GoMotorState, GO_MOTORS] = field(
        default_factory=lambda: [GoMotorState() for _ in range(GO_MOTORS)]
    )
    bms_state: GoBmsState = field(default_factory=GoBmsState)
    foot_force: array[int16, 4] = _zeros(4)
    """FR, FL, RR, RL."""
    foot_force_est: array[int16, 4] = _zeros(4)
    tick: uint32 = 0
    """The robot's clock, in milliseconds."""
    wireless_remote: array[uint8, 40] = _bytes(40)
    bit_flag: uint8 = 0
    adc_reel: float32 = 0.0
    temperature_ntc1: uint8 = 0
    temperature_ntc2: uint8 = 0
    power_v: float32 = 0.0
    power_a: float32 = 0.0
    fan_frequency: array[uint16, 4] = _zeros(4)
    reserve: uint32 = 0
    crc: uint32 = 0


# unitree_hg: the G1


@dataclass
@annotate.final
@annotate.autoid("sequential")
class HgMotorCmd(IdlStruct, typename="unitree_hg::msg::dds_::MotorCmd_"):
    mode: uint8 = 0
    q: float32 = 0.0
    dq: float32 = 0.0
    tau: float32 = 0.0
    kp: float32 = 0.0
    kd: float32 = 0.0
    reserve: uint32 = 0


@dataclass
@annotate.final
@annotate.autoid("sequential")
class HgMotorState(IdlStruct, typename="unitree_hg::msg::dds_::MotorState_"):
    mode: uint8 = 0
    q: float32 = 0.0
    dq: float32 = 0.0
    ddq: float32 = 0.0
    tau_est: float32 = 0.0
    temperature: array[int16, 2] = _zeros(2)
    vol: float32 = 0.0
    sensor: array[uint32, 2] = _zeros(2)
    motorstate: uint32 = 0
    reserve: array[uint32, 4] = _zeros(4)


@dataclass
@annotate.final
@annotate.autoid("sequential")
class HgIMUState(IdlStruct, typename="unitree_hg::msg::dds_::IMUState_"):
    quaternion: array[float32, 4] = field(default_factory=lambda: [1.0, 0.0, 0.0, 0.0])
    """[w, x, y, z]."""
    gyroscope: array[float32, 3] = _zeros(3, 0.0)
    accelerometer: array[float32, 3] = _zeros(3, 0.0)
    rpy: array[float32, 3] = _zeros(3, 0.0)
    temperature: int16 = 0


@dataclass
@annotate.final
@annotate.autoid("sequential")
class HgLowCmd(IdlStruct, typename="unitree_hg::msg::dds_::LowCmd_"):
    mode_pr: uint8 = 0
    mode_machine: uint8 = 0
    motor_cmd: array[HgMotorCmd, HG_MOTORS] = field(
        default_factory=lambda: [HgMotorCmd() for _ in range(HG_MOTORS)]
    )
    reserve: array[uint32, 4] = _zeros(4)
    crc: uint32 = 0


@dataclass
@annotate.final
@annotate.autoid("sequential")
class HgLowState(IdlStruct, typename="unitree_hg::msg::dds_::LowState_"):
    version: array[uint32, 2] = _zeros(2)
    mode_pr: uint8 = 0
    mode_machine: uint8 = 0
    tick: uint32 = 0
    """The robot's clock, in milliseconds."""
    imu_state: HgIMUState = field(default_factory=HgIMUState)
    motor_state: array[HgMotorState, HG_MOTORS] = field(
        default_factory=lambda: [HgMotorState() for _ in range(HG_MOTORS)]
    )
    wireless_remote: array[uint8, 40] = _bytes(40)
    reserve: array[uint32, 4] = _zeros(4)
    crc: uint32 = 0


LOWSTATE = "rt/lowstate"
"""The DDS topic of the robot's readings."""
LOWCMD = "rt/lowcmd"
"""The DDS topic of the commands to the robot."""


def _fast_cdr() -> None:
    from judo.unitree import cdr

    cdr.install(GoLowCmd, GoLowState, HgLowCmd, HgLowState)


_fast_cdr()  # the four messages on the wire serialize through judo.unitree.cdr
