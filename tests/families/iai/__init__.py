"""Tests of the IAI protocol B family."""
