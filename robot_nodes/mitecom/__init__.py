"""Team communication: Mitecom (codec) and HL protobuf (protobuf_codec) <-> TeammateReport; node.MitecomNode."""

from robot_nodes.mitecom.codec import MitecomError
from robot_nodes.mitecom.protobuf_codec import TeamMessageError
from robot_nodes.mitecom.report import SeenRobot, TeammateReport

__all__ = ["MitecomError", "SeenRobot", "TeamMessageError", "TeammateReport"]
