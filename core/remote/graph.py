"""The served desk in the ROS 2 graph: rmw_zenoh's liveliness tokens for a node, its publishers
and its subscriptions, so ``ros2 node list``, ``ros2 topic list/info/echo`` see it.

rmw_zenoh (``liveliness_utils.cpp``, design document "Graph Cache") keys each entity's token as::

    @ros2_lv/<domain>/<zid>/<nid>/<id>/<kind>/<enclave>/<namespace>/<node>[/<topic>/<type>/<hash>/<qos>]

- ``zid``: the Zenoh session id (hex); ``nid``: the node's id in this session; ``id``: the entity's
  id (the node's own id for its NN token);
- ``kind``: NN node, MP publisher, MS subscription, SS service server, SC service client;
- names are mangled: every ``/`` becomes ``%`` (the root namespace and enclave ``/`` -> ``%``);
- ``type``: the DDS-mangled type (``std_msgs::msg::dds_::String_``), ``hash``: RIHS01 or
  ``TypeHashNotSupported`` (Humble);
- ``qos``: ``reliability:durability:history,depth:deadline_s,deadline_ns:lifespan_s,lifespan_ns:``
  ``liveliness,lease_s,lease_ns`` with a field left empty where it equals rmw's default profile
  (reliable, volatile, keep last 10): ``::,:,:,:,,`` for a default publisher.
"""
from __future__ import annotations

from dataclasses import dataclass

from core.remote import ros

ADMIN_SPACE = "@ros2_lv"
NODE, PUBLISHER, SUBSCRIPTION = "NN", "MP", "MS"
NODE_NAME = "deskarm_server"
# rmw QoS enum values (rmw/types.h)
RELIABLE, BEST_EFFORT = 1, 2
TRANSIENT_LOCAL, VOLATILE = 1, 2
KEEP_LAST = 1
DEFAULT_DEPTH = 10


def mangle(name: str) -> str:
    """rmw_zenoh's name mangling: ``/`` -> ``%`` (so ``/`` alone, the root, is ``%``)."""
    return str(name).replace("/", "%")


@dataclass(frozen=True)
class Qos:
    """The QoS fields rmw_zenoh writes into a token (others at rmw's defaults)."""

    reliability: int = RELIABLE
    durability: int = VOLATILE
    depth: int = DEFAULT_DEPTH

    def key(self) -> str:
        rel = "" if self.reliability == RELIABLE else str(self.reliability)
        dur = "" if self.durability == VOLATILE else str(self.durability)
        depth = "" if self.depth == DEFAULT_DEPTH else str(self.depth)
        return f"{rel}:{dur}:,{depth}:,:,:,,"


LATCHED = Qos(durability=TRANSIENT_LOCAL, depth=1)


def node_token(domain_id: int, zid: str, nid: int, name: str = NODE_NAME, namespace: str = "/",
               enclave: str = "/") -> str:
    """The NN token of a node."""
    return f"{ADMIN_SPACE}/{int(domain_id)}/{zid}/{nid}/{nid}/{NODE}/{mangle(enclave)}/{mangle(namespace)}/{mangle(name)}"


def entity_token(kind: str, domain_id: int, zid: str, nid: int, eid: int, topic: str, msgtype: str,
                 hash_style: str = "rihs01", qos: Qos = Qos(), name: str = NODE_NAME, namespace: str = "/",
                 enclave: str = "/") -> str:
    """The MP (publisher) or MS (subscription) token of ``topic``."""
    if kind not in (PUBLISHER, SUBSCRIPTION):
        raise ValueError(f"entity kind {kind!r}: expected {PUBLISHER} or {SUBSCRIPTION}")
    return (f"{ADMIN_SPACE}/{int(domain_id)}/{zid}/{nid}/{eid}/{kind}/{mangle(enclave)}/{mangle(namespace)}/"
            f"{mangle(name)}/{mangle(topic)}/{ros.dds_type_name(msgtype)}/{ros.type_hash(msgtype, hash_style)}/"
            f"{qos.key()}")


def parse_token(key: str) -> dict:
    """The fields of a token (ValueError when it is not rmw_zenoh's format)."""
    parts = str(key).split("/")
    if len(parts) not in (9, 13) or parts[0] != ADMIN_SPACE or parts[5] not in ("NN", "MP", "MS", "SS", "SC"):
        raise ValueError(f"{key!r} is not an rmw_zenoh liveliness token")
    out = {"domain": int(parts[1]), "zid": parts[2], "nid": parts[3], "id": parts[4], "kind": parts[5],
           "enclave": parts[6].replace("%", "/"), "namespace": parts[7].replace("%", "/"),
           "node": parts[8].replace("%", "/")}
    if len(parts) == 13:
        dds = parts[10]
        pkg, kind, _, name = dds.split("::")
        out.update(topic=parts[9].replace("%", "/"), type=f"{pkg}/{kind}/{name[:-1]}", hash=parts[11], qos=parts[12])
    return out


def server_tokens(domain_id: int, zid: str, publishers: dict[str, str], subscriptions: dict[str, str],
                  hash_style: str = "rihs01", latched: tuple[str, ...] = ()) -> list[str]:
    """Every token of the server's node: NN, one MP per published topic, one MS per command topic."""
    nid = 0
    tokens = [node_token(domain_id, zid, nid)]
    eid = 1
    for topic, msgtype in publishers.items():
        qos = LATCHED if topic in latched else Qos()
        tokens.append(entity_token(PUBLISHER, domain_id, zid, nid, eid, topic, msgtype, hash_style, qos))
        eid += 1
    for topic, msgtype in subscriptions.items():
        tokens.append(entity_token(SUBSCRIPTION, domain_id, zid, nid, eid, topic, msgtype, hash_style))
        eid += 1
    return tokens
