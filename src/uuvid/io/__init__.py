"""uuvid.io"""
