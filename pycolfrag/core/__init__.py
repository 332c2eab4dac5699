"""The bottom layer every other package stands on: the C library's one import site (:mod:`.ffi`), the
entry-type checks (:mod:`.validate`), the errors, the names of IMs and EDPs (:mod:`.names`), reading a
file a user names (:mod:`.input_files`), scipy on first use, the digest of the C sources, the version
(:mod:`.version`, a leaf), the commands' help style (:mod:`.help`), BLAS threads and progress bars.

Nothing here imports a layer above it (tests/test_layers.py).
"""
