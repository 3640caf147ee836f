"""Tests of the Epson RC+ Remote Control family."""
