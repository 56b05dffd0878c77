"""What both ends of a Unitree link share: the DDS domain on a chosen network interface, the two
topics and their QoS. The QoS are the ROS 2 link's (`judo.ros2.link`): readings best effort, keep
last 1 (a reader that matches any writer); commands reliable, keep last 1 (a writer that matches a
reliable or a best-effort reader)."""

from typing import Any

from judo.core.errors import ConfigError
from judo.ros2 import link
from judo.unitree.messages import LOWCMD, LOWSTATE

STATE_QOS = link.SENSOR_QOS
COMMAND_QOS = link.COMMAND_QOS


def interface_config(interface: str) -> str:
    """The Cyclone DDS configuration that puts a domain on the network interface `interface` (e.g.
    eth0, lo)."""
    if not interface or any(c in interface for c in "<>&\"' "):
        raise ConfigError(
            "--unitree.interface must name a network interface such as eth0 or lo, got "
            f"{interface!r}"
        )
    return (
        '<CycloneDDS><Domain Id="any"><General><Interfaces>'
        f'<NetworkInterface name="{interface}" priority="default" multicast="default"/>'
        "</Interfaces></General></Domain></CycloneDDS>"
    )


_DOMAINS: dict[int, tuple[str, Any, int]] = {}
"""The domains this process opened on an interface: domain -> (interface, cyclonedds Domain, links
using it). A domain is configured once per process, before its first participant."""


def _open_domain(domain: int, interface: str) -> None:
    from cyclonedds.core import DDSException
    from cyclonedds.domain import Domain

    if domain in _DOMAINS:
        named, handle, users = _DOMAINS[domain]
        if named != interface:
            raise ConfigError(
                f"DDS domain {domain} is already open on interface {named!r} in this "
                f"process, not {interface!r}"
            )
        _DOMAINS[domain] = (named, handle, users + 1)
        return
    try:
        handle = Domain(domain, interface_config(interface))
    except DDSException as err:
        raise ConfigError(
            f"DDS domain {domain} is already open in this process without "
            f"--unitree.interface {interface}: "
            f"open the interface's link first ({err})"
        ) from None
    _DOMAINS[domain] = (interface, handle, 1)


def _close_domain(domain: int) -> None:
    named, handle, users = _DOMAINS[domain]
    if users > 1:
        _DOMAINS[domain] = (named, handle, users - 1)
        return
    del _DOMAINS[domain]
    handle.__del__()


class Link:
    """A DDS participant on `domain` (0..232), on `interface` where given (None: Cyclone's default,
    or the interface this process already opened the domain on), with the topics rt/lowstate and
    rt/lowcmd of the given types.

    Attributes:
        participant: the DDS participant; `state_topic`, `command_topic`: its two topics.
    """

    def __init__(
        self, domain: int, interface: str | None, state_type: type, command_type: type
    ) -> None:
        from cyclonedds.topic import Topic

        self.domain = link.domain_id(domain)
        self._interface = interface
        if interface is not None:
            _open_domain(self.domain, interface)
        try:
            self.participant = link.participant(self.domain)
            self.state_topic = Topic(self.participant, LOWSTATE, state_type)
            self.command_topic = Topic(self.participant, LOWCMD, command_type)
        except BaseException:
            if interface is not None:
                _close_domain(self.domain)
            raise

    def close(self) -> None:
        """Delete the participant and everything it made, now (and the domain, after its last
        link)."""
        link.close_participant(self.participant)
        if self._interface is not None:
            _close_domain(self.domain)
            self._interface = None
