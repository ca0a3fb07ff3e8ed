"""VDA 5050 3.0 over MQTT: every AGV speaks the industry's AGV interface (docs/vda5050.md)."""
