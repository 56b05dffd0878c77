"""What both ends of a Unitree link share: the DDS domain on a chosen network interface, the two topics and their
QoS. The QoS are the ROS 2 link's (`judo.ros2.link`): readings best effort, keep last 1 (a reader that matches any
writer); commands reliable, keep last 1 (a writer that matches a reliable or a best-effort reader)."""

from judo.core.errors import ConfigError
from judo.ros2 import link
from judo.unitree.messages import LOWCMD, LOWSTATE

STATE_QOS = link.SENSOR_QOS
COMMAND_QOS = link.COMMAND_QOS


def interface_config(interface: str) -> str:
    """The Cyclone DDS configuration that puts a domain on the network interface `interface` (e.g. eth0, lo)."""
    if not interface or any(c in interface for c in "<>&\"' "):
        raise ConfigError(f"--unitree.interface must name a network interface such as eth0 or lo, got {interface!r}")
    return (
        '<CycloneDDS><Domain Id="any"><General><Interfaces>'
        f'<NetworkInterface name="{interface}" priority="default" multicast="default"/>'
        "</Interfaces></General></Domain></CycloneDDS>"
    )


class Link:
    """A DDS participant on `domain` (0..232), on `interface` where given (None: Cyclone's default), with the
    topics rt/lowstate and rt/lowcmd of `robot`'s message types.

    Attributes:
        participant: the DDS participant; `state_topic`, `command_topic`: its two topics.
    """

    def __init__(self, domain: int, interface: str | None, state_type: type, command_type: type) -> None:
        from cyclonedds.domain import Domain
        from cyclonedds.topic import Topic

        self.domain = link.domain_id(domain)
        self._domain = None if interface is None else Domain(self.domain, interface_config(interface))
        self.participant = link.participant(self.domain)
        self.state_topic = Topic(self.participant, LOWSTATE, state_type)
        self.command_topic = Topic(self.participant, LOWCMD, command_type)

    def close(self) -> None:
        """Delete the participant and everything it made, now."""
        link.close_participant(self.participant)
        if self._domain is not None:
            self._domain.__del__()
            self._domain = None
