"""Message definitions, the topic table and the CDR codec every pitchside process shares."""

from schemas import messages, std
from schemas.codec import Message, SchemaError, constant_names, constants, decode, encode, make, message_class, msgdef
from schemas.json_view import to_dict
from schemas.stamps import header, stamp
from schemas.topics import ACTIONS, SERVICES, TOPICS, Priority, Topic, topic

__all__ = [
    "ACTIONS",
    "SERVICES",
    "TOPICS",
    "Message",
    "Priority",
    "SchemaError",
    "Topic",
    "constant_names",
    "constants",
    "decode",
    "encode",
    "header",
    "make",
    "message_class",
    "messages",
    "msgdef",
    "stamp",
    "std",
    "to_dict",
    "topic",
]
