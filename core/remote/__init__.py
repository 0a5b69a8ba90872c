"""The desk across machines: the pipeline on one machine (``DeskServer``), a client on another
(``DeskClient``), linked by Zenoh with ROS 2 messages (CDR, rosbags' type store).

Peer-to-peer on a LAN by default (Zenoh peer mode, multicast scouting); a router or a fixed
endpoint when given (``LinkOptions``). Key expressions follow rmw_zenoh's design
(``<domain>/<topic>/<pkg>::msg::dds_::<Type>_/<RIHS01 hash>``), see ``core.remote.ros``.
Zenoh is imported only when a session opens, so the package imports without it.
"""
from core.remote.link import LinkOptions
from core.remote.ros import TOPICS, key_expr

__all__ = ["LinkOptions", "TOPICS", "key_expr"]
