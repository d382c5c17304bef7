"""Pure composition of cores: the RS-485 medium and bus, fleets of devices on one clock."""
