"""What every rrps node runs on: the process (``run_nodes``), QoS, parameters, diagnostics,
message conversions, command freshness, supervision of child processes and the recording taps.

Pure modules (no rclpy): ``freshness``, ``supervision``, ``parameter_schema``, ``cdr``,
``recording_bundle``. The others need rclpy.
"""
