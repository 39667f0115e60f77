"""Reference firmware for the acquisition box (not run by the host package)."""
