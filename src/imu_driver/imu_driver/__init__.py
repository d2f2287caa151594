"""MICRO-ISU BP3010 codec, serial driver node, emulator, rosbag2 play and record nodes."""
