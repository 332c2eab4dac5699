"""A site: its sources behind the one :class:`~pycolfrag.site.sources.SiteSource` interface and the
site file (:mod:`.sources`), and the models of rates, pulse occurrence and pulse period they use
(:mod:`.models`). Read by both risk routes (:mod:`pycolfrag.risk`, :mod:`pycolfrag.rare`)."""
from pycolfrag.site.sources import (  # noqa: F401 (the site file's public names)
    SOURCE_TYPES,
    Events,
    Site,
    SiteSource,
    load_site,
    site_from_dict,
    source_type,
)
