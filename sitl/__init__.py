"""The simulated world: sea, BlueROV2 Heavy plant, T200 thrusters, and the tools that run them."""
