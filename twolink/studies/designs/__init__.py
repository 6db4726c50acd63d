"""The designs: FCM rule base, gains, sensing, calibration, linear frontier, table search."""
