"""Launch files, process runner, demo and report for the whole navigation graph."""
