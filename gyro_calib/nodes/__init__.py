"""ROS 2 nodes: thin shells that translate messages to core calls and back."""
