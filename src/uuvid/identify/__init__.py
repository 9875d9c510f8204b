"""uuvid.identify"""
