"""Reading what users write by hand, one way for every file and option: TOML files with
the place of every key and value (``tomlfile``), the place of a character inside a TOML
string (``strings``), durations with their units (``units``), a slave's profile
(``profile``), ``--shard I/N`` and the split of files it names (``shard``), and the
did-you-mean of a misspelt word (``suggest``)."""
