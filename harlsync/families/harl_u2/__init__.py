"""The Hirata HARL-U2 family (HNC-580, RS-232 ASCII, LN/SN commands, LNR interlock).

::

    protocol/     the sans-I/O codec: frames (STX station SP payload ETX LRC), commands
    model.py      programs, steps, tables, timers, registers, the LNR status
    controller.py what the controller can do, over the shared serial link
    tableend.py   where the offset tables end, found with reads only
    catalogue.py  its items, their keys, names and safe push order
    driver.py     the engine's Driver over the controller
    layout.py     the project files: names, format, JSON Schemas (schemas/), their text
    analysis.py   reading the files back into a robot and its data
    checks.py     what the schemas cannot say: against the configuration, the wire
    sim/          the simulated controller
    family.py     all of it as the engine sees it (FAMILY, for the registry)
"""
