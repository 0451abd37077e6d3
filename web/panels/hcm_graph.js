// HCM state graph, as the HCM exports it (hcm_graph): laid out by Graphviz on the server, drawn by state_graph.js.

import { stateGraphPanel } from "./state_graph.js";

export default stateGraphPanel({ id: "hcm", title: "HCM state graph (focused robot)", topic: "hcm_graph", size: [2, 3] });
