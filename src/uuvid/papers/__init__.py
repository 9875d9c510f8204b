"""uuvid.papers"""
