"""What results become: Waveforms, measurements, CSV/raw files and figures."""
