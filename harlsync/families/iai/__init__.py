"""IAI protocol B controllers (TTA, X-SEL, SSEL/ASEL/PSEL, TT): RS-232 ASCII frames
``!`` ... SC CR LF, positions read with 22DH and written with 291H."""
