// State graph of the focused robot: the HCM's (hcm_graph) or its behaviour's (behavior_graph), as each machine
// exports itself; laid out by Graphviz on the server, drawn by state_graph.js.

import { stateGraphPanel } from "./state_graph.js";

export default stateGraphPanel({ id: "hcm", title: "State graph (focused robot)", size: [2, 3],
  topics: [["hcm_graph", "HCM"], ["behavior_graph", "behaviour"]] });
