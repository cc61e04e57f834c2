"""Reading what users write by hand, one way for every file and option: TOML files with
the place of every key and value (``tomlfile``), durations with their units (``units``),
and the did-you-mean of a misspelt word (``suggest``)."""
