"""Pure wire formats and sans-I/O protocol cores shared by devices and host."""
