"""Pure wire formats shared by the devices and the host side (no I/O): ALA1 checksums and
conversion-table files, HCTMPS1 frames and CRC, XMODEM, and the device contract of the runtime."""
