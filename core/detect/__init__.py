"""Detectors beyond markers: colour, circles, a learned detector, trackers and filtering (in progress)."""
