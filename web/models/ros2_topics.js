// The ROS 2 robots the dashboard hears (GET /api/ros2/robots) as rows of a table: one per topic, whether it
// reaches a panel, and if not, why ("definition missing", a type hash that does not match). Pure, for node --test.

/** @typedef {{name: string, type: string, type_hash: string, status: string, panel: string | null}} Ros2Topic */
/** @typedef {{robot: string, domain: number, nodes: string[], topics: Ros2Topic[]}} Ros2Robot */
/** @typedef {{domains: number[], profile: string, robots: Ros2Robot[], why_empty?: string}} Ros2Answer */
/** @typedef {{robot: string, domain: number, topic: string, type: string, status: string, panel: string,
 *   shown: boolean}} Ros2Row */

/** Rows sorted by robot, then the topics not shown first (what needs a look), then by name.
 * @param {Ros2Answer} answer @returns {Ros2Row[]} */
export function ros2Rows(answer) {
  const rows = [];
  for (const robot of answer.robots ?? []) {
    for (const topic of robot.topics ?? []) {
      rows.push({ robot: robot.robot, domain: robot.domain, topic: topic.name, type: topic.type,
        status: topic.status, panel: topic.panel ?? "", shown: topic.status === "shown" });
    }
  }
  return rows.sort((a, b) => a.robot.localeCompare(b.robot) || Number(a.shown) - Number(b.shown)
    || a.topic.localeCompare(b.topic));
}

/** One line above the table: the domains and profile, how many topics are not shown, or why nothing is heard.
 * @param {Ros2Answer} answer @returns {string} */
export function ros2Summary(answer) {
  if (answer.why_empty) return answer.why_empty;
  const rows = ros2Rows(answer);
  const hidden = rows.filter((row) => !row.shown).length;
  const robots = (answer.robots ?? []).length;
  return `domains ${answer.domains.join(", ")} · profile ${answer.profile} · ${robots} robot${robots === 1 ? "" : "s"}`
    + ` · ${rows.length} topics${hidden ? `, ${hidden} not shown` : ""}`;
}
