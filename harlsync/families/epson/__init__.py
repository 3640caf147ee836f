"""Epson RC+ 8.0 controllers through the Remote Control function: 16-bit command
and response words and a 7-signal handshake in the Remote I/O, over Modbus TCP."""
