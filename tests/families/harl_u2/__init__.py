"""The HARL-U2's own tests: its protocol, controller, simulator, layout and example project."""
