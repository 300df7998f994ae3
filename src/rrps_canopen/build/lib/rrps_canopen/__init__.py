"""CANopen hardware of RRPS robots: the CiA 402 leg drives and the grippers' I/O behind the
driver's hardware interface (:mod:`rrps_canopen.robot`), the master robot's drives
(:mod:`rrps_canopen.master_hardware`) and a virtual CAN bus kept on this machine
(:mod:`rrps_canopen.loopback_bus`). The drive simulator is a package of its own,
:mod:`rrps_canopen_sim`."""
