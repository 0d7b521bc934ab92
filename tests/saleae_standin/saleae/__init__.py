"""A stand-in for the ``saleae`` package Logic 2 embeds, for the tests of the
generated analyzer (tests/saleae_logic.py puts it on ``sys.path``): the parts
of its API a High Level Analyzer uses, as Saleae documents them, and strict
where Logic 2 would fail (a data value it cannot show, a time that is not a
``GraphTime``, arithmetic the API does not have). Python 3.8 runs it too
(tests/integration/test_saleae_extension.py), as Logic 2's Python would."""
