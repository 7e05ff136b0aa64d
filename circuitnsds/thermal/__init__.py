"""Loss data and heat: the PLECS thermal description reader (:mod:`.plecs`), the datasheet's
tables (:mod:`.tables`), Foster and Cauer networks (:mod:`.networks`), and each device's
losses and junction temperature from a run's waveforms (:mod:`.device_losses`,
:mod:`.junction`)."""
