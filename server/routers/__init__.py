"""REST and WebSocket routers, one per resource."""
