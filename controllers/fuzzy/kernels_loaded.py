"""Importing this module loads the compiled fuzzy kernels (:func:`kernels.warm`): an entry
of the process pools' fork-server preload (:mod:`twolink.foundation.executors`), so that every
worker forked from the server starts with them (~0.3 s a worker otherwise: numba's
import and its on-disk cache, at the first chunk). Without numba it does nothing."""

from twolink.controllers.fuzzy import kernels

kernels.warm()
