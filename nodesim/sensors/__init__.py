"""Sensors: what the node's IMU, the encoder and a magnetometer read, and how they are characterised.

Modules: :mod:`~nodesim.sensors.imu` (full IMU at the sensor rate: misalignment, biases, Gauss-Markov,
bias instability, white noise, temperature, clipping, int16 counts, per-tick averaging),
:mod:`~nodesim.sensors.chain_imu` (the MPU6500 count model every chain node reads),
:mod:`~nodesim.sensors.noise` (the error processes), :mod:`~nodesim.sensors.catalogue` (MPU6500, VN-100T,
STIM300, iPST-RQH, DIP), :mod:`~nodesim.sensors.encoder`, :mod:`~nodesim.sensors.magnetometer`,
:mod:`~nodesim.sensors.node_imu` (one node's true IMU inputs along a drilling process and its sensor-rate
record), :mod:`~nodesim.sensors.allan` (Allan variance) and :mod:`~nodesim.sensors.calibration`.
"""
