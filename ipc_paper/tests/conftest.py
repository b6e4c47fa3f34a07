"""Test-wide settings: proved certificates are remembered in a private cache, not the user's."""

from __future__ import annotations

import os
import tempfile

os.environ.setdefault("ROA_CACHE_DIR", tempfile.mkdtemp(prefix="roa-test-cache-"))
