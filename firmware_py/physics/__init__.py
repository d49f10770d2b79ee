"""Physics shared by the firmware (nominal parameters) and the SITL world (true parameters)."""
