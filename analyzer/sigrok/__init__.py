"""sigrok jobs (docs/instruments.md, "The sigrok decoder"): the protocol decoder
``gimbal`` for PulseView and sigrok-cli, generated from the command table
(``decoder``), and its installation (``install``)."""
