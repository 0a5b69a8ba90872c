"""The desk across machines: the pipeline on one machine (``DeskServer``), a client on another
(``DeskClient``), linked by Zenoh with ROS 2 messages (CDR, rosbags' type store).

Local by default (the server listens on 127.0.0.1, no scouting); on the network only with the
credentials ``deskarm serve --pair`` makes (``core.remote.security``: Zenoh user/password and
mutual TLS, access control by key expression — a controller drives, a viewer watches and may
STOP). Every command payload is checked by ``core.remote.commands``. Key expressions follow
rmw_zenoh's design (``<domain>/<topic>/<pkg>::msg::dds_::<Type>_/<RIHS01 hash>``, see
``core.remote.ros``) and so do the graph's liveliness tokens (``core.remote.graph``).
Zenoh is imported only when a session opens, so the package imports without it.
"""
from core.remote.link import LinkOptions
from core.remote.ros import TOPICS, key_expr

__all__ = ["LinkOptions", "TOPICS", "key_expr"]
