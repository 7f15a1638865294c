"""The corpus draws the same examples whatever ran before it in the process.

Hypothesis (since 6.131) mixes literals collected from the source of every *local* module already
imported (``sys.modules`` outside site-packages and the standard library, tests excluded) into its
draws of integers and floats: with probability 5 to 15 % a draw is replaced by one of them, and the
random stream then depends on how many there are. ``derandomize=True`` fixes the seed but not that
pool, so importing ``linflex.linearize`` (a Kane linearization in an earlier test) changed the
loops this corpus generated. No setting turns the feature off; for the tests of this folder the
pool of local literals is emptied (the global pool of nasty values, ``0``, ``-0.0``, ``1e-308``,
``nan`` bounds and the like, stays), and the cache of permitted constants is cleared on entry and
exit so that neither side sees the other's pool.
"""

from __future__ import annotations

import pytest
from hypothesis.internal.conjecture import providers


@pytest.fixture(autouse=True)
def _no_local_constants(monkeypatch):
    empty = providers.Constants()
    monkeypatch.setattr(providers, "_get_local_constants", lambda: empty)
    providers.CONSTANTS_CACHE.cache.clear()
    yield
    providers.CONSTANTS_CACHE.cache.clear()
