"""Strapdown INS and loosely coupled INS/GPS error-state Kalman filter."""
