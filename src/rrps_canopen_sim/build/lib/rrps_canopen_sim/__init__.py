"""The CiA 402 drive simulator: simulated drives and I/O on a CAN bus, one process per bus
(``rrps-drive-sim``)."""
