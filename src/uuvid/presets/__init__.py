"""uuvid.presets"""
