"""The servo bus node: one interface (ServoBackend), a MuJoCo and a Dynamixel backend."""
