"""uuvid.cli"""
