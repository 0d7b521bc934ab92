"""sigrok jobs (docs/instruments-sigrok-decoder.md): the protocol decoder
``gimbal`` for PulseView and sigrok-cli, generated from the command table
(``decoder``), and its installation (``install``)."""
