// The address carries the view (?preset=lab&robot=robot2): a link opens the same layout and focused robot on
// another laptop. Read once at start; kept up to date with history.replaceState (no reload, no new history entry).

const PRESET = "preset", ROBOT = "robot";

/** {preset, robot} as the address names them ("" for what it does not name). */
export function viewFromAddress(search = location.search) {
  const params = new URLSearchParams(search);
  return { preset: params.get(PRESET) ?? "", robot: params.get(ROBOT) ?? "" };
}

/** The address with this preset and robot (other parameters kept). */
export function showInAddress(preset, robot) {
  const url = new URL(location.href);
  url.searchParams.set(PRESET, preset);
  if (robot) url.searchParams.set(ROBOT, robot); else url.searchParams.delete(ROBOT);
  if (url.href !== location.href) history.replaceState(history.state, "", url);
}
