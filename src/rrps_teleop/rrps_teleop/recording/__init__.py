"""Recording and replay of the rrps topics as MCAP (the ros2 profile), and the robot for RViz2.

Pure modules (no rclpy): ``schemas`` (ros2msg definitions), ``qos`` (offered_qos_profiles as
rosbag2 writes them), ``mcap_files`` (MCAP files, rotation), ``ring`` (the flight recorder's
window), ``triggers`` (fault triggers), ``replay`` (reading, timing, the command remap),
``markers`` (MarkerArray and /tf geometry). The nodes are ``rrps_teleop.nodes.recorder_node``,
``replay_node`` and ``markers_node``; the commands ``rrps-record`` and ``rrps-replay``.
"""
