"""The process plumbing every command shares, under the numerics: atomic writes and staged
sets of files ([`files`][pes_ref.core.runtime.files]), ``.npz`` archives of named arrays read without
pickle ([`npz`][pes_ref.core.runtime.npz]), signals ([`signals`][pes_ref.core.runtime.signals]),
the one reader of keyed TOML files ([`keyfile`][pes_ref.core.runtime.keyfile]), progress with the
time left ([`progress`][pes_ref.core.runtime.progress]) and the memory of a run's large arrays
([`pages`][pes_ref.core.runtime.pages]). It imports nothing else of pes_ref
(setup.cfg's import-linter contract)."""
