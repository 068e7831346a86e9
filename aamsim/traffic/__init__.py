"""Aircraft state, performance envelopes, routes, autopilot and the step kernel."""
