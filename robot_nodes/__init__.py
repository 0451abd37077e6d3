"""Robot nodes: each its own process, all talking over Zenoh through the runtime."""
