"""Streaming db8 wavelet multi-resolution denoiser for IMU data."""
