"""What pen's own tests and benches share: truth worlds, campaign builders, an independent reference integration.

- :mod:`~pencli.testing.campaigns`: campaigns of the simulated rig (``pen acquire``'s ``sim`` driver) with hidden
  effects, and the rules a diagnosis is judged by;
- :mod:`~pencli.testing.holdout_world` and :mod:`~pencli.testing.world_three`: two rig simulators written apart
  from pen's model and from its ``sim`` driver, whose campaigns measure the diagnosis and are never tuned on;
- :mod:`~pencli.testing.reference`: an independent integration of CONTRACT §2 (the physics oracle);
- :mod:`~pencli.testing.helpers`: run folders written by hand, workspace snapshots;
- :mod:`~pencli.testing.options`: the benches' command-line check.

Nothing in pen's commands, API or core imports this package (a layering test keeps it so): the truth a test
checks against never comes from the code under test.
"""
