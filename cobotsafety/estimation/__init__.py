"""State estimation shared by the sensor pipeline and the human-aware control."""
