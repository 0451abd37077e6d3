// node --test tests/web/: the ROS 2 robots panel's rows (web/models/ros2_topics.js).
import { test } from "node:test";
import assert from "node:assert/strict";
import { ros2Rows, ros2Summary } from "../../web/models/ros2_topics.js";

const ANSWER = {
  domains: [0, 11], profile: "bitbots",
  robots: [
    { robot: "amy", domain: 11, nodes: ["/hcm"], topics: [
      { name: "/robot_state", type: "bitbots_msgs/msg/RobotControlState", type_hash: "RIHS01_a", status: "shown",
        panel: "robot_state" },
      { name: "/vision/debug", type: "bitbots_msgs/msg/Unknown", type_hash: "RIHS01_b",
        status: "definition missing", panel: null },
    ] },
    { robot: "amber", domain: 12, nodes: [], topics: [] },
  ],
};

test("a topic that is not shown comes first and says why", () => {
  const rows = ros2Rows(ANSWER);
  assert.deepEqual(rows.map((row) => [row.topic, row.status, row.shown]), [
    ["/vision/debug", "definition missing", false], ["/robot_state", "shown", true]]);
  assert.equal(rows[1].panel, "robot_state");
  assert.equal(rows[0].panel, "");
});

test("the summary counts robots and topics not shown, or says why nothing is heard", () => {
  assert.equal(ros2Summary(ANSWER), "domains 0, 11 · profile bitbots · 2 robots · 2 topics, 1 not shown");
  assert.equal(ros2Summary({ domains: [0], profile: "pitchside", robots: [], why_empty: "match mode: no Zenoh session" }),
    "match mode: no Zenoh session");
});
