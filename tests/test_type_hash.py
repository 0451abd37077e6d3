"""RIHS01 type hashes against the hashes ROS 2 itself published (rmw_zenoh's design.md, rosidl's generated code,
rosbag2's MCAP files), including the cases a hash library gets wrong: char fields, bounded sequences and strings,
nested arrays, empty messages, services (request, response, event) and actions."""

from __future__ import annotations

from pathlib import Path

import pytest
from mcap.reader import make_reader
from rosbags.typesys import Stores, get_typestore

from schemas import codec
from schemas.definitions import SCHEMA_DIR, file_texts, parse_texts
from schemas.interface_folder import InterfaceFolderError, load_interfaces
from schemas.type_hash import TypeHashError, type_description, type_hash
from tests.support import TESTDATA

JAZZY = get_typestore(Stores.ROS2_JAZZY).fielddefs

# from rmw_zenoh's docs/design.md (0.2.x), the issue, and rosidl's generated std_msgs/service_msgs code
PUBLISHED_STANDARD = {
    "std_msgs/msg/String": "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18",
    "sensor_msgs/msg/JointState": "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e",
    "rcl_interfaces/msg/Log": "RIHS01_e28ce254ca8abc06abf92773b74602cdbf116ed34fbaf294fb9f81da9f318eac",
    # `char data`: rosidl hashes a .msg char as uint8; rosbags' own hash_rihs01 gives RIHS01_8914cecc... here
    "std_msgs/msg/Char": "RIHS01_3ad2d04dd29ba19d04b16659afa3ccaedd691914b02a64e82e252f2fa6a586a9",
    # char[16] client_gid: a fixed array of char
    "service_msgs/msg/ServiceEventInfo": "RIHS01_41bcbbe07a75c9b52bc96bfd5c24d7f0fc0a08c0cb7921b3373c5732345a6f45",
    "unique_identifier_msgs/msg/UUID": "RIHS01_1b8e8aca958cbea28fe6ef60bf6c19b683c97a9ef60bb34752067d0f2f7ab437",
    "builtin_interfaces/msg/Time": "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197",
    # seen in the /parameter_events tokens of a running rmw_zenoh talker
    "rcl_interfaces/msg/ParameterEvent": "RIHS01_043e627780fcad87a22d225bc2a037361dba713fca6a6b9f4b869a5aa0393204",
}

# rosidl's generated test_msgs (*__description.c of a Kilted build) for ros2/test_interface_files' definitions
PUBLISHED_TEST_MSGS = {
    "test_msgs/msg/Arrays":
        "RIHS01_8a321b80dae8c44dfd1ce558eaf1b1cd5ebbe5950863ed675836535511a7f91a",
    "test_msgs/msg/BasicTypes":
        "RIHS01_7c300afd4e796798d49bdd6cdaa0fa87fa0ed2ba3217d977e1faa87070d797ab",
    "test_msgs/msg/BoundedSequences":
        "RIHS01_fb361a3b3827c76a142c2190126a20a92e7e510e047f880141a7e9ef867961ed",
    "test_msgs/msg/Constants":
        "RIHS01_983e7ae7099d65b3030c31c2890b0ec2b332484fae9f28c68e01340c8f61edcf",
    "test_msgs/msg/Defaults":
        "RIHS01_a725ee02bf25a224cb7d14015a0245b6654ff591ae1ac277e2a2673f013ea6d2",
    "test_msgs/msg/UnboundedSequences":
        "RIHS01_a63975514293a2c6b24a807675bcbd9180bda1995dd4ee10f2698d45ff77db05",
    "test_msgs/msg/MultiNested":
        "RIHS01_9ee9cbfb17c2df991a750b761a56def78674034977c829449820ca07efd9758b",
    "test_msgs/msg/Strings":
        "RIHS01_eee55533636293ac7c94c62432eedb5777eb849847d2a17b4dcead8c4a20ab32",
    "test_msgs/msg/Empty":
        "RIHS01_6587ceacfdb97a895b60774d021011c64f8c7299f53322404af4036dec6142dc",
    "test_msgs/srv/BasicTypes":
        "RIHS01_da348697437c103cc9a9322ac1bdbdcf8eb11a85de22f7f2492ca1df416e1a5f",
    "test_msgs/srv/BasicTypes_Request":
        "RIHS01_1dafcf389e224692783e9c4f6066ba0db3fa75fdbd8f081ffbe7ed03144d73d4",
    "test_msgs/srv/BasicTypes_Response":
        "RIHS01_8479b3defe554d969e81c6cf8cdaf0b97b4fcd76928b2d644c6813b032673c0d",
    "test_msgs/srv/BasicTypes_Event":
        "RIHS01_5b9988a4805a06ae22dff12903a774ccda710e9514926b826ffc884e3a9a982e",
    "test_msgs/action/Fibonacci":
        "RIHS01_be9273e3557225044b4a040811112491f7079326e3a573f83258b0b4c30bd069",
    "test_msgs/action/Fibonacci_Goal":
        "RIHS01_e58ef5a8f4f039ab522a740823547c460b1d5aed8031c8b7825d33d345d90df8",
    "test_msgs/action/Fibonacci_Result":
        "RIHS01_0774b095467813c6904d475498b5486b7ebd4cda6a4569f97e8de8c862689049",
    "test_msgs/action/Fibonacci_Feedback":
        "RIHS01_7d1110f2efa019ad5ad8ad2244db98d862f39dc9fae8c976814b0065fa2f32d5",
    "test_msgs/action/Fibonacci_SendGoal":
        "RIHS01_d807633803e38e164276573cd97e9fbd71e109c290bbf4cc312a0a1c9da7bbd9",
    "test_msgs/action/Fibonacci_SendGoal_Request":
        "RIHS01_dfe75c73dc2c090cbc8fd8c45039bfa279d16aa6aadd348f812c6adad26e669e",
    "test_msgs/action/Fibonacci_SendGoal_Response":
        "RIHS01_1e7e84f7edf1fb020d9e51c7842bceef4cbdbd847f354125f3227cf4f314a683",
    "test_msgs/action/Fibonacci_SendGoal_Event":
        "RIHS01_a20e708c6aae7a99d1eb0e930a0916f596bb5bae93a342a61752e13135be2c44",
    "test_msgs/action/Fibonacci_GetResult":
        "RIHS01_5d30fdeb21d20e117aa5f36c7b4f0b6874f1a8cf7a9c038d58f1156c5737b209",
    "test_msgs/action/Fibonacci_GetResult_Request":
        "RIHS01_c65e93c4c4328d7f1abd6ace83dba8e5fa0f32de76b4d2c96b5c655d94803b92",
    "test_msgs/action/Fibonacci_GetResult_Response":
        "RIHS01_ef88159d47a3d21d9bf4bec690cf668939d9542db28a9cfd77dbcd97eaf1add2",
    "test_msgs/action/Fibonacci_GetResult_Event":
        "RIHS01_fe0aa5843ef10550a9b322aeeccd5b11e78bca05b3571cf6999c51bff30c1e23",
    "test_msgs/action/Fibonacci_FeedbackMessage":
        "RIHS01_37487bae8cea358366b97003c1ef1ca7ce7c08df36f9e8cca496624226aee64e",
}


@pytest.fixture(scope="module")
def test_msgs() -> dict:
    return {**JAZZY, **load_interfaces(TESTDATA / "ros2_test_interfaces")}


@pytest.mark.parametrize("name", sorted(PUBLISHED_STANDARD))
def test_standard_types_hash_as_ros2_publishes(name: str) -> None:
    assert type_hash(name, JAZZY) == PUBLISHED_STANDARD[name]


@pytest.mark.parametrize("name", sorted(PUBLISHED_TEST_MSGS))
def test_test_msgs_hash_as_rosidl_generated(name: str, test_msgs: dict) -> None:
    assert type_hash(name, test_msgs) == PUBLISHED_TEST_MSGS[name]


def test_add_two_ints_service_hash_is_rmw_zenohs_example(tmp_path: Path) -> None:
    (tmp_path / "example_interfaces" / "srv").mkdir(parents=True)
    (tmp_path / "example_interfaces" / "srv" / "AddTwoInts.srv").write_text("int64 a\nint64 b\n---\nint64 sum\n")
    defs = {**JAZZY, **load_interfaces(tmp_path)}
    assert type_hash("example_interfaces/srv/AddTwoInts", defs) == (
        "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a")


def _mcap_channels_with_hash() -> list[tuple[str, str, str, str]]:
    rows = []
    for path in sorted((TESTDATA / "mcap").glob("*.mcap")):
        with path.open("rb") as stream:
            summary = make_reader(stream).get_summary()
        assert summary is not None
        for channel in summary.channels.values():
            schema = summary.schemas[channel.schema_id]
            if channel.metadata.get("topic_type_hash"):
                rows.append((path.name, schema.name, schema.data.decode(), channel.metadata["topic_type_hash"]))
    return rows


def test_hashes_recorded_by_rosbag2_in_mcap_files() -> None:
    """rosbag2 writes each channel's hash beside its definition text: hash the text, compare (a service's event
    channel carries the .srv text)."""
    rows = _mcap_channels_with_hash()
    assert {name for _, name, _, _ in rows} >= {"test_msgs/msg/Strings", "test_msgs/srv/BasicTypes_Event"}
    for filename, name, text, recorded in rows:
        if name.endswith("_Event") and "/srv/" in name:
            service = name.removesuffix("_Event")
            request, response = text.split("\n---\n")
            defs = parse_texts({f"{service}_Request": request, f"{service}_Response": response})
        else:
            defs = parse_texts({name: text})
        assert type_hash(name, {**JAZZY, **defs}) == recorded, (filename, name)


def test_field_kinds_as_rep_2011_numbers_them(test_msgs: dict) -> None:
    """The ids behind the hashes above, spelled out for the hard cases."""
    fields = {f["name"]: f["type"] for f in
              type_description("test_msgs/msg/BoundedSequences", test_msgs)["type_description"]["fields"]}
    assert fields["char_values"] == {"type_id": 96 + 3, "capacity": 3, "string_capacity": 0, "nested_type_name": ""}
    assert fields["byte_values"]["type_id"] == 96 + 16
    assert fields["basic_types_values"] == {"type_id": 96 + 1, "capacity": 3, "string_capacity": 0,
                                            "nested_type_name": "test_msgs/msg/BasicTypes"}
    strings = {f["name"]: f["type"] for f in
               type_description("test_msgs/msg/Strings", test_msgs)["type_description"]["fields"]}
    assert strings["bounded_string_value"] == {"type_id": 21, "capacity": 0, "string_capacity": 22,
                                               "nested_type_name": ""}
    empty = type_description("test_msgs/msg/Empty", test_msgs)["type_description"]["fields"]
    assert [f["name"] for f in empty] == ["structure_needs_at_least_one_member"]


def test_default_values_and_constants_do_not_change_the_hash() -> None:
    plain = parse_texts({"demo_msgs/msg/Limits": "int32 low\nfloat64 high\n"})
    decorated = parse_texts({"demo_msgs/msg/Limits": "int8 KIND=3\nint32 low 5\nfloat64 high 1.5  # metres\n"})
    assert type_hash("demo_msgs/msg/Limits", plain) == type_hash("demo_msgs/msg/Limits", decorated)
    renamed = parse_texts({"demo_msgs/msg/Limits": "int32 low\nfloat64 top\n"})
    assert type_hash("demo_msgs/msg/Limits", renamed) != type_hash("demo_msgs/msg/Limits", plain)


def test_pitchside_types_hash_from_the_typestore_as_from_their_files() -> None:
    """codec.type_hash (the process's typestore) and the folder loader (the .msg/.srv/.action files) agree, for
    every message, service and action of our own packages."""
    from_files = {**JAZZY, **load_interfaces(SCHEMA_DIR)}
    names = set()
    for path in (SCHEMA_DIR / "humanoid_league_msgs").glob("*/*.*"):
        kind = path.parent.name
        names.add(f"humanoid_league_msgs/{kind}/{path.stem}")
    names |= {f"pitchside_msgs/msg/{p.stem}" for p in (SCHEMA_DIR / "pitchside_msgs" / "msg").glob("*.msg")}
    assert "humanoid_league_msgs/action/PlayAnimation" in names and "humanoid_league_msgs/srv/ManualPenalize" in names
    for name in names:
        assert codec.type_hash(name) == type_hash(name, from_files), name
    assert codec.type_hash("sensor_msgs/JointState") == PUBLISHED_STANDARD["sensor_msgs/msg/JointState"]


def test_another_teams_folder_hashes_what_it_defines() -> None:
    defs = {**JAZZY, **load_interfaces(TESTDATA / "ros2_interfaces")}
    assert type_hash("bitbots_msgs/msg/RobotControlState", defs).startswith("RIHS01_")
    # soccer_vision_2d_msgs refers to vision_msgs, which the folder does not hold: a clear error, not a wrong hash
    with pytest.raises(TypeHashError, match="no definition of vision_msgs/msg/"):
        type_hash("soccer_vision_2d_msgs/msg/BallArray", defs)


def test_bad_definitions_raise_typed_errors(tmp_path: Path) -> None:
    with pytest.raises(TypeHashError, match="no definition of nowhere_msgs/msg/Missing"):
        type_hash("nowhere_msgs/msg/Missing", JAZZY)
    (tmp_path / "broken_msgs" / "srv").mkdir(parents=True)
    (tmp_path / "broken_msgs" / "srv" / "Three.srv").write_text("int8 a\n---\nint8 b\n---\nint8 c\n")
    with pytest.raises(InterfaceFolderError, match=r"Three\.srv"):
        load_interfaces(tmp_path)
    with pytest.raises(InterfaceFolderError, match="not a folder"):
        load_interfaces(tmp_path / "absent")
    with pytest.raises(ValueError, match="this one 3"):
        file_texts(tmp_path / "broken_msgs" / "srv" / "Three.srv")
