"""The bag layer: rosbag2 MCAP bags and tables of the topic contract, and nothing above them.

It knows bags and message layouts only — reading and inspecting bags
(:mod:`~gyro_calib.bagio.reader`), writing them, the columnar MCAP decoder
(:mod:`~gyro_calib.bagio.columns`), CSV/text tables read wherever a bag is
(:mod:`~gyro_calib.bagio.tables`) and its named errors. It never imports the method registry,
the sessions or the methods: the layers above hand it the topics they want (issue 19 §5;
``test/test_layers.py`` keeps it so). The old import paths ``gyro_calib.bag``,
``gyro_calib.mcap_columns`` and ``gyro_calib.table_input`` re-export these modules.
"""
