"""The Hirata HARL-U2 family (HNC-580, RS-232 ASCII, LN/SN commands)."""
